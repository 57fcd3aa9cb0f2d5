// Motion-only bundle adjustment: the camera pose that best explains a set of
// 3D-2D(+depth) correspondences with fixed 3D points.
//
// Residuals of observation i (point X_i in the world, observed undistorted
// pixel (u_i, v_i), optional depth z_i, pixel sigma s_i, static weight w_i,
// rolling-shutter correction C_i = row_cam_from_cam, identity by default),
// with P = C_i * cam_from_world * X_i = (x, y, z):
//   reprojection  r_uv = ((fx x/z + cx - u_i) / s_i, (fy y/z + cy - v_i) / s_i)
//   depth         r_d  = (bf / z - bf / z_i) / (s_i * disparity_sigma_scale)
// The depth residual is the disparity error of a virtual stereo camera with
// baseline b = virtual_baseline (bf = fx * b), as ORB-SLAM treats RGB-D: the
// predicted right-image coordinate is u_R = u - bf / z. Working in disparity
// (inverse depth) makes the depth noise about constant, since Kinect-type
// depth noise grows like z^2. Observations without a valid depth have only
// r_uv. The squared norm e_i^2 = |r_i|^2 is chi-square with 2 or 3 degrees of
// freedom for inliers.
//
// Cost: sum_i w_i * rho(e_i^2) over the current inliers, rho = Huber with
// delta = sqrt(chi2 threshold of the observation's kind) (or the identity
// when huber = false). The static weight multiplies the robust cost; the
// chi-square test uses the unweighted error, so a feature is classified by
// geometry and weighted by the mask.
//
// Optimisation: `rounds` rounds of at most `iterations_per_round`
// Levenberg-Marquardt iterations; after each round every observation (also
// the earlier outliers) is classified by e_i^2 <= chi2 (and z > 0), and the
// next round uses the inliers only; the rounds stop early once the
// classification no longer changes. An LM round ends when the step is below
// 1e-8 or the cost decreases by less than 1e-10 of itself.
//
// Solvers:
//  - kEigenLm: hand-written LM on SE(3): left perturbation
//    cam_from_world <- Exp(delta) * cam_from_world with delta = (rho, phi),
//    analytic Jacobians, 6x6 normal equations (H + lambda diag(H)) solved by
//    LDLT, gain-ratio control of lambda. This is the default: on the
//    tracker's problems (100..1000 observations) it is several times faster
//    than Ceres (see tests/bench/tracker_bench.cc, BM_OptimizePose*).
//  - kCeres: the same cost with Ceres (automatic derivatives, Eigen
//    quaternion manifold + translation, HuberLoss inside ScaledLoss, dense
//    QR, LM), kept for cross-checking and the benchmark.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/camera.h"
#include "common/rigid3.h"

namespace dypho {

struct PoseObservation {
  Eigen::Vector3d point_world = Eigen::Vector3d::Zero();  // fixed 3D point [m]
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();        // observed undistorted pixel [px]
  double depth = 0.0;   // observed camera z [m]; <= 0 or non-finite = no depth residual
  double sigma = 1.0;   // pixel noise std [px] (ORB: scale_factor^level), > 0
  double weight = 1.0;  // static weight in [0, 1] multiplying the robust cost
  // Rolling shutter: the camera when this observation's image row was read,
  // from the camera at the frame's reference time (identity for a global
  // shutter). Fixed during the optimisation.
  Rigid3d row_cam_from_cam;
};

enum class PoseSolver { kEigenLm, kCeres };

struct PoseOptimizerOptions {
  PoseSolver solver = PoseSolver::kEigenLm;  // LM implementation (see header comment)
  int rounds = 4;                            // optimisation rounds with outlier classification, >= 1
  int iterations_per_round = 10;             // LM iterations per round, >= 1
  double chi2_mono = 5.991;                  // inlier threshold on e^2, reprojection only (95%, 2 DoF), > 0
  double chi2_depth = 7.815;                 // inlier threshold on e^2 with depth (95%, 3 DoF), > 0
  bool huber = true;                         // Huber loss with delta = sqrt(chi2); false = least squares
  double virtual_baseline = 0.08;            // [m] baseline b of the virtual stereo camera, > 0
  double disparity_sigma_scale = 1.0;        // disparity std relative to the pixel sigma, > 0
  int min_inliers = 3;                       // fewer inliers after a round -> stop, result not usable, >= 3

  bool IsValid(std::string* error) const;
};

struct PoseOptimizerResult {
  Rigid3d cam_from_world;     // the estimate (the initial pose when nothing could be done)
  std::vector<char> inliers;  // per observation, after the last round
  int num_inliers = 0;        // count of inliers
  double cost = 0.0;          // final robust cost over the inliers (sum w * rho(e^2))
  int iterations = 0;         // LM iterations done over all rounds
  bool usable = false;        // at least min_inliers inliers and a finite pose
};

// Optimises `initial_cam_from_world`. Uses fx, fy, cx, cy of `camera` (the
// pixels are already undistorted). Throws InvalidInput for invalid options,
// a non-finite initial pose or an observation with a non-finite point or
// pixel or sigma <= 0 (naming its index); never throws for a bad geometry
// (points behind the camera become outliers).
PoseOptimizerResult OptimizePose(const Camera& camera, const std::vector<PoseObservation>& observations,
                                 const Rigid3d& initial_cam_from_world, const PoseOptimizerOptions& options);

}  // namespace dypho
