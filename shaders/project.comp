#version 450
// Per-Gaussian projection (kernels/math/preprocess.h ProjectGaussian): world
// parameters -> screen-space splat, colour from SH, sort key.
#extension GL_GOOGLE_include_directive : require
#include "splat_common.glsl"

layout(local_size_x = 128) in;

layout(std140, set = 0, binding = 0) uniform Camera { CameraBlock cam; };
layout(std430, set = 0, binding = 1) readonly buffer Means { float means[]; };           // [N, 3]
layout(std430, set = 0, binding = 2) readonly buffer LogScales { float log_scales[]; };  // [N, 3]
layout(std430, set = 0, binding = 3) readonly buffer Quats { float quats[]; };           // [N, 4]
layout(std430, set = 0, binding = 4) readonly buffer Logits { float logits[]; };         // [N]
layout(std430, set = 0, binding = 5) readonly buffer Sh { float sh[]; };                 // [N, K, 3]
layout(std430, set = 0, binding = 6) writeonly buffer Splats { vec4 splats[]; };         // [N, 4]
layout(std430, set = 0, binding = 7) writeonly buffer Keys { uint keys[]; };             // [N]
layout(std430, set = 0, binding = 8) writeonly buffer Values { uint values[]; };         // [N]
layout(std430, set = 0, binding = 9) buffer Stats { uint stats[]; };  // visible, non-finite

// 3 x 3 matrix from rows (GLSL constructors take columns).
mat3 FromRows(vec3 r0, vec3 r1, vec3 r2) { return transpose(mat3(r0, r1, r2)); }

vec3 ShColor(int degree, uint base, vec3 dir) {
  const float C0 = 0.28209479177387814;
  const float C1 = 0.4886025119029199;
  const float C2[5] = float[5](1.0925484305920792, -1.0925484305920792, 0.31539156525252005,
                               -1.0925484305920792, 0.5462742152960396);
  const float C3[7] = float[7](-0.5900435899266435, 2.890611442640554, -0.4570457994644658,
                               0.3731763325901154, -0.4570457994644658, 1.445305721320277,
                               -0.5900435899266435);
  float Y[16];
  const float x = dir.x, y = dir.y, z = dir.z;
  Y[0] = C0;
  if (degree >= 1) {
    Y[1] = -C1 * y;
    Y[2] = C1 * z;
    Y[3] = -C1 * x;
  }
  if (degree >= 2) {
    const float xx = x * x, yy = y * y, zz = z * z;
    Y[4] = C2[0] * x * y;
    Y[5] = C2[1] * y * z;
    Y[6] = C2[2] * (2.0 * zz - xx - yy);
    Y[7] = C2[3] * x * z;
    Y[8] = C2[4] * (xx - yy);
    if (degree >= 3) {
      Y[9] = C3[0] * y * (3.0 * xx - yy);
      Y[10] = C3[1] * x * y * z;
      Y[11] = C3[2] * y * (4.0 * zz - xx - yy);
      Y[12] = C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy);
      Y[13] = C3[4] * x * (4.0 * zz - xx - yy);
      Y[14] = C3[5] * z * (xx - yy);
      Y[15] = C3[6] * x * (xx - 3.0 * yy);
    }
  }
  vec3 color = vec3(0.5);
  const int K = (degree + 1) * (degree + 1);
  for (int k = 0; k < K; ++k) {
    const uint o = base + 3u * uint(k);
    color += Y[k] * vec3(sh[o], sh[o + 1u], sh[o + 2u]);
  }
  return max(color, vec3(0.0));
}

void main() {
  const uint i = gl_GlobalInvocationID.x;
  const uint n = uint(cam.size.z);
  if (i >= n) return;
  splats[4u * i] = vec4(0.0);
  splats[4u * i + 1u] = vec4(0.0);
  splats[4u * i + 2u] = vec4(0.0);
  splats[4u * i + 3u] = vec4(0.0);
  // Sort keys: sorted mode orders by depth; the order-independent mode only
  // moves the visible Gaussians first (key 0), keeping index order (one
  // stable radix pass). Not drawn: the largest key, sorted last.
  const bool oit = cam.options.y != 0;
  keys[i] = oit ? 1u : 0xffffffffu;
  values[i] = i;

  const int degree = cam.options.x;
  const int active_coeffs = (degree + 1) * (degree + 1);
  const uint sh_base = 3u * uint(cam.size.w) * i;
  const vec3 m = vec3(means[3u * i], means[3u * i + 1u], means[3u * i + 2u]);
  const vec3 ls = vec3(log_scales[3u * i], log_scales[3u * i + 1u], log_scales[3u * i + 2u]);
  const vec4 q = vec4(quats[4u * i], quats[4u * i + 1u], quats[4u * i + 2u], quats[4u * i + 3u]);
  const float logit = logits[i];
  bool finite = IsFinite(logit);
  for (int k = 0; k < 3; ++k) finite = finite && IsFinite(m[k]) && IsFinite(ls[k]);
  for (int k = 0; k < 4; ++k) finite = finite && IsFinite(q[k]);
  for (int k = 0; k < 3 * active_coeffs; ++k) finite = finite && IsFinite(sh[sh_base + uint(k)]);
  const float qn2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
  if (!finite || !(qn2 > 1e-24)) {
    atomicAdd(stats[1], 1u);
    return;
  }
  const float opacity = 1.0 / (1.0 + exp(-logit));
  if (!(opacity >= kMinAlpha)) return;

  // Covariance: R(q) diag(exp(ls)), Sigma = M M^T (covariance.h).
  const float inv = 1.0 / sqrt(qn2);
  const float w = q.x * inv, x = q.y * inv, y = q.z * inv, z = q.w * inv;
  mat3 M = FromRows(vec3(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)),
                    vec3(2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)),
                    vec3(2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)));
  for (int j = 0; j < 3; ++j) M[j] *= exp(ls[j]);
  const mat3 sigma = M * transpose(M);

  // World -> camera (projection.h TransformToCamera).
  const mat3 R = FromRows(cam.rot0.xyz, cam.rot1.xyz, cam.rot2.xyz);
  const vec3 t = vec3(cam.rot0.w, cam.rot1.w, cam.rot2.w);
  const vec3 mc = R * m + t;
  const mat3 sigma_c = R * sigma * transpose(R);
  if (!(mc.z >= cam.planes.x && mc.z <= cam.planes.y)) return;

  // Perspective projection with the clamped Jacobian (PerspectiveProject).
  const float fx = cam.intrinsics.x, fy = cam.intrinsics.y;
  const float rz = 1.0 / mc.z;
  const float tx = mc.z * clamp(mc.x * rz, -cam.limits.x, cam.limits.y);
  const float ty = mc.z * clamp(mc.y * rz, -cam.limits.z, cam.limits.w);
  mat3x2 J = mat3x2(0.0);  // 3 columns, 2 rows
  J[0][0] = fx * rz;
  J[2][0] = -fx * tx * rz * rz;
  J[1][1] = fy * rz;
  J[2][1] = -fy * ty * rz * rz;
  const mat2 cov2d = J * sigma_c * transpose(J);
  const vec2 mean2d = vec2(fx * mc.x * rz + cam.intrinsics.z, fy * mc.y * rz + cam.intrinsics.w);

  // Dilated conic (DilatedConic) and 3-sigma radius (Radius3Sigma).
  const float low_pass = cam.planes.z;
  const float a = cov2d[0][0] + low_pass, b = 0.5 * (cov2d[1][0] + cov2d[0][1]), c = cov2d[1][1] + low_pass;
  const float det = a * c - b * b;
  if (!(det > 0.0)) return;
  const float idet = 1.0 / det;
  const float A = c * idet, B = -b * idet, C = a * idet;
  const float rb = cov2d[1][0];
  const float mid = 0.5 * (a + c);
  const float disc = mid * mid - (a * c - rb * rb);
  const float lambda = mid + sqrt(disc > 0.1 ? disc : 0.1);
  const int radius = int(ceil(3.0 * sqrt(lambda)));
  if (!(radius > 0)) return;
  const float r = float(radius);
  if (mean2d.x + r < 0.0 || mean2d.x - r > float(cam.size.x - 1) || mean2d.y + r < 0.0 ||
      mean2d.y - r > float(cam.size.y - 1)) {
    return;
  }

  // Contribution threshold (blend.h PowerThreshold) and the enlarged
  // culling ellipse (CullingPowerMin) whose bounding box the quad covers.
  const float alpha_limit = -log(255.0 * opacity);
  const float power_min = alpha_limit > -0.5 * kMaxSigma2 ? alpha_limit : -0.5 * kMaxSigma2;
  const float r2 = -2.0 * (power_min * 1.001 - 0.0005);
  const float cdet = A * C - B * B;
  const float ext_x = sqrt(r2 * C / cdet), ext_y = sqrt(r2 * A / cdet);

  const vec3 raw_dir = m - cam.center.xyz;
  const vec3 color = ShColor(degree, sh_base, raw_dir / sqrt(dot(raw_dir, raw_dir)));

  // OIT depth weight (blend.h OitWeight).
  const float za = mc.z / 5.0, zb = mc.z / 200.0;
  const float zb3 = zb * zb * zb;
  const float f = clamp(10.0 / (1e-5 + za * za + zb3 * zb3), 1e-2, 3e3);

  splats[4u * i] = vec4(mean2d, ext_x, ext_y);
  splats[4u * i + 1u] = vec4(A, B, C, power_min);
  splats[4u * i + 2u] = vec4(color, opacity);
  splats[4u * i + 3u] = vec4(mc.z, f, 0.0, 0.0);
  keys[i] = oit ? 0u : floatBitsToUint(mc.z);  // z > 0: the bits order like the floats
  atomicAdd(stats[0], 1u);
}
