// The residual of one feature observation, shared by motion-only bundle
// adjustment (tracker/pose_optimizer.cc) and local bundle adjustment
// (tracker/backend/local_ba.cc): for the point p in the camera that read the
// feature's row, the pixel error (fx x/z + cx - u, fy y/z + cy - v) / sigma and,
// with depth, the disparity error (bf / z - bf / depth) / sigma_d, bf being fx
// times the virtual baseline (as stereo ORB-SLAM treats RGB-D depth).
#pragma once

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

}  // namespace dypho
