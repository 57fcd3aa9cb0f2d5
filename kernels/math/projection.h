// From world to screen: rigid transform, EWA perspective projection
// (Zwicker et al. 2002, "EWA Splatting"; as used by Kerbl et al. 2023), the
// low-pass dilation and the 2D conic, each beside its VJP.
#pragma once

#include "kernels/math/types.h"

namespace dypho::kernels::math {

// ---------------------------------------------------------------------------
// World -> camera:  mean_c = R p + t,  Sigma_c = R Sigma R^T.
template <typename T>
DYPHO_HD inline void TransformToCamera(const Mat3<T>& R, const Vec3<T>& t, const Vec3<T>& mean,
                                       const Mat3<T>& sigma, Vec3<T>* mean_c, Mat3<T>* sigma_c) {
  *mean_c = R * mean + t;
  *sigma_c = R * sigma * glm::transpose(R);
}

// VJP. v_R and v_t are accumulated (+=); v_mean and v_sigma are written.
//   v_mean = R^T v_mean_c;  v_R += v_mean_c mean^T;  v_t += v_mean_c
//   v_sigma = R^T v_sigma_c R;  v_R += (v_sigma_c + v_sigma_c^T) R Sigma   (Sigma symmetric)
template <typename T>
DYPHO_HD inline void TransformToCameraVjp(const Mat3<T>& R, const Vec3<T>& mean, const Mat3<T>& sigma,
                                          const Vec3<T>& v_mean_c, const Mat3<T>& v_sigma_c,
                                          Vec3<T>* v_mean, Mat3<T>* v_sigma, Mat3<T>* v_R, Vec3<T>* v_t) {
  const Mat3<T> Rt = glm::transpose(R);
  *v_mean = Rt * v_mean_c;
  *v_sigma = Rt * v_sigma_c * R;
  *v_R += glm::outerProduct(v_mean_c, mean) + (v_sigma_c + glm::transpose(v_sigma_c)) * R * sigma;
  *v_t += v_mean_c;
}

// ---------------------------------------------------------------------------
// Perspective projection of mean and covariance.
//   mean2d = (fx x / z + cx, fy y / z + cy)
//   cov2d  = J Sigma_c J^T with J = [[fx/z, 0, -fx tx/z^2], [0, fy/z, -fy ty/z^2]]
// where (tx, ty) = z * clamp((x, y) / z) keeps J bounded for Gaussians far
// outside the view: the tangent is clamped to the image's field of view
// extended by 30% of its half-width (as in 3DGS and gsplat).
struct ProjectionLimits {
  float x_neg, x_pos, y_neg, y_pos;  // tangent limits, all > 0
};

DYPHO_HD inline ProjectionLimits MakeProjectionLimits(float fx, float fy, float cx, float cy, int width,
                                                      int height) {
  const float tan_fovx = 0.5f * width / fx;
  const float tan_fovy = 0.5f * height / fy;
  ProjectionLimits lim;
  lim.x_neg = (cx + 0.5f) / fx + 0.3f * tan_fovx;
  lim.x_pos = (width - 0.5f - cx) / fx + 0.3f * tan_fovx;
  lim.y_neg = (cy + 0.5f) / fy + 0.3f * tan_fovy;
  lim.y_pos = (height - 0.5f - cy) / fy + 0.3f * tan_fovy;
  return lim;
}

template <typename T>
DYPHO_HD inline void PerspectiveProject(const Vec3<T>& mean_c, const Mat3<T>& sigma_c, T fx, T fy, T cx,
                                        T cy, const ProjectionLimits& lim, Vec2<T>* mean2d,
                                        Mat2<T>* cov2d) {
  const T x = mean_c.x, y = mean_c.y, z = mean_c.z;
  const T rz = T(1) / z;
  const T tx = z * Clamp(x * rz, T(-lim.x_neg), T(lim.x_pos));
  const T ty = z * Clamp(y * rz, T(-lim.y_neg), T(lim.y_pos));
  Mat2x3<T> J(T(0));
  J[0][0] = fx * rz;
  J[2][0] = -fx * tx * rz * rz;
  J[1][1] = fy * rz;
  J[2][1] = -fy * ty * rz * rz;
  *cov2d = J * sigma_c * glm::transpose(J);
  *mean2d = Vec2<T>(fx * x * rz + cx, fy * y * rz + cy);
}

// VJP: (v_mean2d, v_cov2d) -> v_mean_c (accumulated), v_sigma_c (written).
//   v_sigma_c = J^T v_cov2d J;  v_J = (v_cov2d + v_cov2d^T) J Sigma_c
//   dJ00/dz = -fx/z^2; dJ11/dz = -fy/z^2;
//   J02 = -fx x / z^2 (unclamped): dJ02/dx = -fx/z^2, dJ02/dz = 2 fx x / z^3
//   J02 = -fx c / z   (clamped, c constant): dJ02/dz = fx c / z^2   (same for J12)
template <typename T>
DYPHO_HD inline void PerspectiveProjectVjp(const Vec3<T>& mean_c, const Mat3<T>& sigma_c, T fx, T fy,
                                           const ProjectionLimits& lim, const Vec2<T>& v_mean2d,
                                           const Mat2<T>& v_cov2d, Vec3<T>* v_mean_c,
                                           Mat3<T>* v_sigma_c) {
  const T x = mean_c.x, y = mean_c.y, z = mean_c.z;
  const T rz = T(1) / z, rz2 = rz * rz, rz3 = rz2 * rz;
  const T ux = x * rz, uy = y * rz;
  const bool clamp_x = ux < T(-lim.x_neg) || ux > T(lim.x_pos);
  const bool clamp_y = uy < T(-lim.y_neg) || uy > T(lim.y_pos);
  const T tx = z * Clamp(ux, T(-lim.x_neg), T(lim.x_pos));
  const T ty = z * Clamp(uy, T(-lim.y_neg), T(lim.y_pos));
  Mat2x3<T> J(T(0));
  J[0][0] = fx * rz;
  J[2][0] = -fx * tx * rz2;
  J[1][1] = fy * rz;
  J[2][1] = -fy * ty * rz2;
  *v_sigma_c = glm::transpose(J) * v_cov2d * J;
  const Mat2x3<T> v_J = (v_cov2d + glm::transpose(v_cov2d)) * J * sigma_c;
  Vec3<T> g(T(0));
  // mean2d
  g.x += fx * rz * v_mean2d.x;
  g.y += fy * rz * v_mean2d.y;
  g.z -= (fx * x * v_mean2d.x + fy * y * v_mean2d.y) * rz2;
  // J00, J11
  g.z -= fx * rz2 * v_J[0][0] + fy * rz2 * v_J[1][1];
  // J02
  if (clamp_x) {
    g.z += fx * (tx * rz) * rz2 * v_J[2][0];
  } else {
    g.x -= fx * rz2 * v_J[2][0];
    g.z += T(2) * fx * x * rz3 * v_J[2][0];
  }
  // J12
  if (clamp_y) {
    g.z += fy * (ty * rz) * rz2 * v_J[2][1];
  } else {
    g.y -= fy * rz2 * v_J[2][1];
    g.z += T(2) * fy * y * rz3 * v_J[2][1];
  }
  *v_mean_c += g;
}

// ---------------------------------------------------------------------------
// Low-pass dilation and inverse: conic = (cov2d + low_pass I)^{-1}.
// Returns false when the dilated covariance is not positive definite.
template <typename T>
DYPHO_HD inline bool DilatedConic(const Mat2<T>& cov2d, T low_pass, Mat2<T>* conic) {
  const T a = cov2d[0][0] + low_pass, b = T(0.5) * (cov2d[1][0] + cov2d[0][1]), c = cov2d[1][1] + low_pass;
  const T det = a * c - b * b;
  if (!(det > T(0))) return false;
  const T inv = T(1) / det;
  (*conic)[0][0] = c * inv;
  (*conic)[1][1] = a * inv;
  (*conic)[1][0] = (*conic)[0][1] = -b * inv;
  return true;
}

// VJP of the inverse: d(C^{-1}) = -C^{-1} dC C^{-1}  =>  v_cov2d = -conic^T v_conic conic^T.
template <typename T>
DYPHO_HD inline Mat2<T> DilatedConicVjp(const Mat2<T>& conic, const Mat2<T>& v_conic) {
  const Mat2<T> ct = glm::transpose(conic);
  return -(ct * v_conic * ct);
}

// 3-sigma radius [px] of the dilated 2D covariance: 3 sqrt(largest eigenvalue),
// rounded up.
template <typename T>
DYPHO_HD inline int Radius3Sigma(const Mat2<T>& cov2d, T low_pass) {
  const T a = cov2d[0][0] + low_pass, b = cov2d[1][0], c = cov2d[1][1] + low_pass;
  const T mid = T(0.5) * (a + c);
  const T det = a * c - b * b;
  const T disc = mid * mid - det;
  const T lambda = mid + sqrt(disc > T(0.1) ? disc : T(0.1));
  // Compared before the conversion to int (NaN or beyond int range would be
  // undefined): 0 culls, and a radius is capped at 2^30 px.
  const T radius = ceil(T(3) * sqrt(lambda));
  if (!(radius > T(0))) return 0;
  return radius < T(1 << 30) ? static_cast<int>(radius) : (1 << 30);
}

}  // namespace dypho::kernels::math
