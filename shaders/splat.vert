#version 450
// One screen-aligned quad per Gaussian covering the bounding box of
// its (slightly enlarged) cut-off ellipse, clipped to the image. The
// fragment shader does the exact per-pixel test.
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
  // The box of the enlarged cut-off ellipse already holds every pixel centre
  // that passes the exact test; 1/32 px of margin covers the rasterizer's
  // snapping of vertex positions (sub-pixel precision >= 4 bits).
  vec2 ext = s0.zw + 1.0 / 32.0;
  if (pc.points != 0u) ext = vec2(pc.point_radius + 0.5);
  // Pixel (u, v) has its centre at u (our convention) = u + 0.5 in
  // framebuffer coordinates.
  vec2 fb = s0.xy + 0.5 + (pc.quad_vertices == 4u ? kCorners4[corner] : kCorners6[corner]) * ext;
  fb = clamp(fb, vec2(-1.0), pc.viewport.xy + 1.0);
  gl_Position = vec4(fb / pc.viewport.xy * 2.0 - 1.0, 0.0, 1.0);
}
