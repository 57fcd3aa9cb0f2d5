#version 450
// Radix sort, step 1 of 3 per 8-bit digit: thread i counts the digits of its
// block of `items` consecutive keys into column i of hist[digit][thread].
// Each column belongs to one thread, so no atomics are needed.
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 1) buffer Hist { uint hist[]; };  // [256, threads]
layout(push_constant) uniform Push {
  uint n;        // keys
  uint shift;    // digit = (key >> shift) & 255
  uint items;    // keys per thread
  uint threads;  // columns of hist
} pc;

void main() {
  const uint t = gl_GlobalInvocationID.x;
  if (t >= pc.threads) return;
  for (uint d = 0u; d < 256u; ++d) hist[d * pc.threads + t] = 0u;
  const uint begin = t * pc.items;
  const uint end = min(pc.n, begin + pc.items);
  for (uint e = begin; e < end; ++e) {
    const uint d = (keys[e] >> pc.shift) & 255u;
    hist[d * pc.threads + t] += 1u;
  }
}
