#version 450
// Indirect draw arguments for the visible Gaussians only (the projection
// counted them in stats[0]; sorting put them first): 6 indices (or 6
// vertices) per Gaussian.
layout(local_size_x = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Stats { uint stats[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Args { uint args[]; };

void main() {
  const uint visible = stats[0];
  // VkDrawIndexedIndirectCommand at word 0
  args[0] = 6u * visible;  // indexCount
  args[1] = 1u;            // instanceCount
  args[2] = 0u;            // firstIndex
  args[3] = 0u;            // vertexOffset
  args[4] = 0u;            // firstInstance
  // VkDrawIndirectCommand at word 5 (byte 20)
  args[5] = 6u * visible;  // vertexCount
  args[6] = 1u;
  args[7] = 0u;
  args[8] = 0u;
}
