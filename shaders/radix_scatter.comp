#version 450
// Radix sort, step 3 of 3: thread i moves its keys (in order) to the slots
// counted by the scan, incrementing its own column of hist.
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer KeysIn { uint keys_in[]; };
layout(std430, set = 0, binding = 1) readonly buffer ValuesIn { uint values_in[]; };
layout(std430, set = 0, binding = 2) writeonly buffer KeysOut { uint keys_out[]; };
layout(std430, set = 0, binding = 3) writeonly buffer ValuesOut { uint values_out[]; };
layout(std430, set = 0, binding = 4) buffer Hist { uint hist[]; };
layout(push_constant) uniform Push {
  uint n;
  uint shift;
  uint items;
  uint threads;
} pc;

void main() {
  const uint t = gl_GlobalInvocationID.x;
  if (t >= pc.threads) return;
  const uint begin = t * pc.items;
  const uint end = min(pc.n, begin + pc.items);
  for (uint e = begin; e < end; ++e) {
    const uint key = keys_in[e];
    const uint slot = ((key >> pc.shift) & 255u) * pc.threads + t;
    const uint pos = hist[slot];
    hist[slot] = pos + 1u;
    keys_out[pos] = key;
    values_out[pos] = values_in[e];
  }
}
