#version 450
// Turns the accumulation images into colour, depth and alpha (the formulas of
// kernels/rasterizer.h), written as planar float arrays for the host, and
// optionally an 8-bit RGBA image for display.
layout(local_size_x = 16, local_size_y = 16) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D acc0;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D acc1;
layout(std430, set = 0, binding = 2) writeonly buffer Out { float out_data[]; };  // [H*W*3 | H*W | H*W]
layout(set = 0, binding = 3, rgba8) uniform writeonly image2D display;
layout(push_constant) uniform Push {
  vec4 background;  // rgb
  uint width;
  uint height;
  uint oit;         // 0 sorted, 1 order-independent
  uint to_display;  // 1: also write `display`
} pc;

void main() {
  const uvec2 p = gl_GlobalInvocationID.xy;
  if (p.x >= pc.width || p.y >= pc.height) return;
  const vec4 a0 = imageLoad(acc0, ivec2(p));
  const vec4 a1 = imageLoad(acc1, ivec2(p));
  vec3 color;
  float depth, alpha;
  if (pc.oit == 0u) {
    // a0 = (sum w c, T), a1 = (sum w z, ., ., T)
    color = a0.rgb + a0.a * pc.background.rgb;
    depth = a1.r;
    alpha = 1.0 - a0.a;
  } else {
    // a0 = (sum alpha f c, A), a1 = (sum alpha f z, ., ., P)
    const float A = a0.a, P = a1.a;
    const vec3 mean = A > 0.0 ? a0.rgb / A : vec3(0.0);
    color = mean * (1.0 - P) + P * pc.background.rgb;
    depth = (A > 0.0 ? a1.r / A : 0.0) * (1.0 - P);
    alpha = 1.0 - P;
  }
  const uint pixels = pc.width * pc.height;
  const uint o = p.y * pc.width + p.x;
  out_data[3u * o] = color.r;
  out_data[3u * o + 1u] = color.g;
  out_data[3u * o + 2u] = color.b;
  out_data[3u * pixels + o] = depth;
  out_data[4u * pixels + o] = alpha;
  if (pc.to_display != 0u) imageStore(display, ivec2(p), vec4(clamp(color, 0.0, 1.0), 1.0));
}
