#version 450
// Per-fragment evaluation of one Gaussian with the rasterizer's conic,
// cut-off (3 sigma and alpha >= 1/255) and alpha = min(0.99, o exp(power)).
// Sorted mode (front to back, blend: colour += T * src, T *= 1 - alpha):
//   out0 = (alpha c, alpha), out1 = (alpha z, 0, 0, alpha)
// Order-independent mode (additive; the product of 1 - alpha in out1.a):
//   out0 = (alpha f c, alpha f), out1 = (alpha f z, 0, 0, alpha)
#extension GL_GOOGLE_include_directive : require
#include "splat_common.glsl"

layout(push_constant) uniform Push {
  vec4 viewport;
  uint use_order;
  uint points;
  float point_radius;
  uint oit;
  uint quad_vertices;
} pc;

layout(location = 0) flat in vec4 v_conic;
layout(location = 1) flat in vec4 v_center;
layout(location = 2) flat in vec4 v_color;
layout(location = 0) out vec4 out0;
layout(location = 1) out vec4 out1;

void main() {
  const vec2 p = gl_FragCoord.xy - 0.5;  // integer pixel coordinates
  const float dx = p.x - v_center.x, dy = p.y - v_center.y;
  float alpha;
  if (pc.points != 0u) {
    if (dx * dx + dy * dy > pc.point_radius * pc.point_radius) discard;
    alpha = min(kMaxAlpha, v_center.z);
  } else {
    precise float power = -0.5 * (v_conic.x * dx * dx + v_conic.z * dy * dy) - v_conic.y * dx * dy;
    if (!(power >= v_conic.w)) discard;
    const float a = v_center.z * ExpNonPositive(power);
    alpha = a < kMaxAlpha ? a : kMaxAlpha;
  }
  const float w = pc.oit != 0u ? alpha * v_color.w : alpha;
  out0 = vec4(w * v_color.rgb, w);
  out1 = vec4(w * v_center.w, 0.0, 0.0, alpha);
}
