#version 450
// One quad per Gaussian covering its (slightly enlarged) cut-off ellipse:
// the rectangle along the ellipse's axes (the axis-aligned box, clipped to
// the image, for splats larger than the image). The fragment shader does the
// exact per-pixel test.
#extension GL_GOOGLE_include_directive : require
#include "splat_common.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Splats { vec4 splats[]; };
layout(std430, set = 0, binding = 1) readonly buffer Order { uint order[]; };
layout(push_constant) uniform Push {
  vec4 viewport;    // width, height, 0, 0 [px]
  uint use_order;   // 1: quad k draws Gaussian order[k]; 0: Gaussian k
  uint points;      // 1: draw each Gaussian as a disc of `point_radius` px
  float point_radius;
  uint oit;
  uint quad_vertices;  // 4: indexed quads (index buffer 4k + 0 1 2 2 1 3); 6: two triangles
} pc;

layout(location = 0) flat out vec4 v_conic;   // A, B, C, power_min
layout(location = 1) flat out vec4 v_center;  // mean_x, mean_y, opacity, depth
layout(location = 2) flat out vec4 v_color;   // r, g, b, OIT weight

const vec2 kCorners6[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(-1, 1), vec2(-1, 1), vec2(1, -1), vec2(1, 1));
const vec2 kCorners4[4] = vec2[4](vec2(-1, -1), vec2(1, -1), vec2(-1, 1), vec2(1, 1));

void main() {
  // One non-instanced draw, 4 (indexed) or 6 vertices per Gaussian:
  // software rasterizers such as lavapipe process long vertex runs much
  // faster than many small instances, and the index buffer lets the vertex
  // cache shade each corner once.
  const uint k = uint(gl_VertexIndex) / pc.quad_vertices;
  const uint corner = uint(gl_VertexIndex) % pc.quad_vertices;
  const uint g = pc.use_order != 0u ? order[k] : k;
  const vec4 s0 = splats[4u * g];
  const vec4 s1 = splats[4u * g + 1u];
  const vec4 s2 = splats[4u * g + 2u];
  const vec4 s3 = splats[4u * g + 3u];
  v_conic = s1;
  v_center = vec4(s0.xy, s2.w, s3.x);
  v_color = vec4(s2.xyz, s3.y);
  if (!(s0.z > 0.0)) {
    gl_Position = vec4(-4.0, -4.0, 0.0, 1.0);  // zero area: no fragments
    return;
  }
  // Pixel (u, v) has its centre at u (our convention) = u + 0.5 in
  // framebuffer coordinates.
  const vec2 c = pc.quad_vertices == 4u ? kCorners4[corner] : kCorners6[corner];
  // The rectangle along the axes of the enlarged cut-off ellipse
  // (d^T conic d <= r2, the culling ellipse of CullingPowerMin) holds every
  // pixel centre that passes the exact test, with far fewer fragments than
  // its axis-aligned box for elongated splats. Axes from the conic's
  // eigenvectors; margins cover their float error (1e-3 relative) and the
  // rasterizer's vertex snapping (1/32 px, sub-pixel precision >= 4 bits).
  const float A = s1.x, B = s1.y, C = s1.z;
  const float r2 = -2.0 * (s1.w * 1.001 - 0.0005);
  const float mid = 0.5 * (A + C);
  const float half_gap = sqrt(0.25 * (A - C) * (A - C) + B * B);
  const float mu_small = mid - half_gap, mu_large = mid + half_gap;  // conic eigenvalues
  const float a = mu_small > 0.0 ? sqrt(r2 / mu_small) : 1e30;      // major half-axis [px]
  const float b = sqrt(r2 / mu_large);                               // minor half-axis [px]
  vec2 fb;
  if (pc.points != 0u) {
    fb = s0.xy + 0.5 + c * (pc.point_radius + 0.5);
  } else if (a < 2.0 * max(pc.viewport.x, pc.viewport.y)) {
    // Eigenvector of mu_small: the better conditioned of (B, mu - A) and (mu - C, B).
    const vec2 v1 = vec2(B, mu_small - A), v2 = vec2(mu_small - C, B);
    const vec2 v = dot(v1, v1) >= dot(v2, v2) ? v1 : v2;
    const vec2 e1 = dot(v, v) > 0.0 ? normalize(v) : vec2(1.0, 0.0);  // a circle: any axis
    const vec2 e2 = vec2(-e1.y, e1.x);
    const float margin = 1.0 / 32.0 + 1e-3 * a;
    fb = s0.xy + 0.5 + c.x * (a + margin) * e1 + c.y * (b + margin) * e2;
  } else {
    // Very large splats: the axis-aligned box, clipped to the image (keeps
    // vertex coordinates small; an axis-aligned box stays a superset when
    // its corners are clamped).
    fb = s0.xy + 0.5 + c * (s0.zw + 1.0 / 32.0);
    fb = clamp(fb, vec2(-1.0), pc.viewport.xy + 1.0);
  }
  gl_Position = vec4(fb / pc.viewport.xy * 2.0 - 1.0, 0.0, 1.0);
}
