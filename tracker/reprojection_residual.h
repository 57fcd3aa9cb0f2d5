// The residual of one feature observation, shared by motion-only bundle
// adjustment (tracker/pose_optimizer.cc) and local bundle adjustment
// (tracker/backend/local_ba.cc, tracker/backend/sparse_lm.cc): for the point p
// in the camera that read the feature's row, the pixel error
// (fx x/z + cx - u, fy y/z + cy - v) / sigma and, with depth, the disparity
// error (bf / z - bf / depth) / sigma_d, bf being fx times the virtual
// baseline (as stereo ORB-SLAM treats RGB-D depth). The templated form is for
// Ceres's automatic derivatives; ProjectionResidualJacobian and
// LeftPerturbationJacobian are the analytic derivatives of the hand-written
// Levenberg-Marquardt solvers.
#pragma once

#include <cmath>

#include <Eigen/Core>

namespace dypho {

struct ProjectionIntrinsics {
  double fx, fy, cx, cy, bf;  // bf = fx * virtual baseline [px m]
};

constexpr double kMinProjectionZ = 1e-6;  // [m] a point nearer than this counts as behind the camera

// Writes 2 residuals (3 with kWithDepth); false when p is behind the camera.
template <bool kWithDepth, typename T>
bool ProjectionResidual(const Eigen::Matrix<T, 3, 1>& p, const ProjectionIntrinsics& k, const Eigen::Vector2d& pixel,
                        double inv_depth, double inv_sigma, double inv_sigma_depth, T* residuals) {
  if (p.z() <= T(kMinProjectionZ)) return false;
  const T inv_z = T(1.0) / p.z();
  residuals[0] = (T(k.fx) * p.x() * inv_z + T(k.cx) - T(pixel.x())) * T(inv_sigma);
  residuals[1] = (T(k.fy) * p.y() * inv_z + T(k.cy) - T(pixel.y())) * T(inv_sigma);
  if (kWithDepth) residuals[2] = (T(k.bf) * inv_z - T(k.bf * inv_depth)) * T(inv_sigma_depth);
  return true;
}

// Huber on the squared error: rho(s) = s for s <= d^2, else 2 d sqrt(s) - d^2
// (Ceres's HuberLoss(d)); the identity when `huber` is false. Returns rho and
// sets *slope = rho'(s).
inline double HuberOfSquared(double squared_error, double delta_squared, bool huber, double* slope) {
  if (!huber || squared_error <= delta_squared) {
    *slope = 1.0;
    return squared_error;
  }
  const double e = std::sqrt(squared_error), delta = std::sqrt(delta_squared);
  *slope = delta / e;
  return 2.0 * delta * e - delta_squared;
}

// The residual r at p (z > kMinProjectionZ) and, when dr_dp is not null, its
// derivative dr/dp. Without depth (with_depth false) r(2) = 0 and the third
// row of dr/dp is zero. sigma_d = sigma * disparity_sigma_scale.
inline void ProjectionResidualJacobian(const Eigen::Vector3d& p, const ProjectionIntrinsics& k,
                                       const Eigen::Vector2d& pixel, bool with_depth, double depth, double sigma,
                                       double disparity_sigma_scale, Eigen::Vector3d* r, Eigen::Matrix3d* dr_dp) {
  const double inv_z = 1.0 / p.z(), inv_s = 1.0 / sigma;
  const double x = p.x() * inv_z, y = p.y() * inv_z;
  (*r)(0) = (k.fx * x + k.cx - pixel.x()) * inv_s;
  (*r)(1) = (k.fy * y + k.cy - pixel.y()) * inv_s;
  const double inv_sd = inv_s / disparity_sigma_scale;
  (*r)(2) = with_depth ? (k.bf * inv_z - k.bf / depth) * inv_sd : 0.0;
  if (dr_dp == nullptr) return;
  dr_dp->setZero();
  (*dr_dp)(0, 0) = k.fx * inv_z * inv_s;
  (*dr_dp)(0, 2) = -k.fx * x * inv_z * inv_s;
  (*dr_dp)(1, 1) = k.fy * inv_z * inv_s;
  (*dr_dp)(1, 2) = -k.fy * y * inv_z * inv_s;
  if (with_depth) (*dr_dp)(2, 2) = -k.bf * inv_z * inv_z * inv_sd;
}

// dq/d(delta) of q = T * X under the left perturbation T <- Exp(delta) * T,
// delta = (rho, phi) (translation first, as Rigid3d::Exp): [I, -[q]x].
inline Eigen::Matrix<double, 3, 6> LeftPerturbationJacobian(const Eigen::Vector3d& q) {
  Eigen::Matrix<double, 3, 6> dq_dd;
  dq_dd.leftCols<3>().setIdentity();
  dq_dd.rightCols<3>() << 0.0, q.z(), -q.y(), -q.z(), 0.0, q.x(), q.y(), -q.x(), 0.0;
  return dq_dd;
}

}  // namespace dypho
