#version 450
// Radix sort, step 2 of 3: exclusive prefix sum over hist[digit][thread] in
// that order, so each (digit, thread) gets the first output slot of its keys:
// all smaller digits first, then the same digit from earlier threads (a
// stable sort). One workgroup; invocation j scans a contiguous chunk.
layout(local_size_x = 256) in;
layout(std430, set = 0, binding = 0) buffer Hist { uint hist[]; };
layout(push_constant) uniform Push {
  uint count;  // entries of hist (256 * threads)
} pc;

shared uint partial[256];

void main() {
  const uint j = gl_LocalInvocationID.x;
  const uint chunk = (pc.count + 255u) / 256u;
  const uint begin = min(pc.count, j * chunk);
  const uint end = min(pc.count, begin + chunk);
  uint sum = 0u;
  for (uint e = begin; e < end; ++e) sum += hist[e];
  partial[j] = sum;
  barrier();
  if (j == 0u) {
    uint running = 0u;
    for (uint k = 0u; k < 256u; ++k) {
      const uint v = partial[k];
      partial[k] = running;
      running += v;
    }
  }
  barrier();
  uint running = partial[j];
  for (uint e = begin; e < end; ++e) {
    const uint v = hist[e];
    hist[e] = running;
    running += v;
  }
}
