// Our sparse Levenberg-Marquardt for the bundle adjustment of local_ba.h
// (LocalBaOptions::solver = "eigen"): the same problem and cost as the Ceres
// path, solved with Eigen only.
//
// Unknowns: the free keyframe poses (keyframes with an active observation
// that are not fixed) with a 6-dof left update cam_from_world <-
// Exp(delta) * cam_from_world, delta = (rho, phi) (the motion-only
// optimiser's, tracker/pose_optimizer.h), and the points with an active
// observation (3-dof, additive). Fixed keyframes are held.
//
// Cost (Ceres's convention): 1/2 sum_i w_i rho_i(e_i^2) over the active
// observations, rho_i = Huber with delta^2 = chi2 of the observation's kind
// (or the identity), e_i the residual of local_ba.h's header comment.
// Gauss-Newton model by iteratively reweighted least squares (for Huber this
// is what Ceres's loss-function correction reduces to): H = sum w rho' J^T J,
// g = sum w rho' J^T r, J the analytic Jacobian (tracker/reprojection_residual.h).
//
// Each step solves (H + D / radius) delta = -g, D = diag(H) clamped to
// [1e-6, 1e32], with the points eliminated: every point's 3x3 block
// (damped) is inverted, the reduced camera system (6 per free keyframe) is
// dense and solved by LDLT, then the points are back-substituted. Trust
// region as Ceres's LEVENBERG_MARQUARDT with its default options: radius
// 1e4 at the start; a step is taken when (actual / model cost decrease) >
// 1e-3, and then radius /= max(1/3, 1 - (2 rho - 1)^3) (at most 1e16);
// otherwise radius /= v, v *= 2 (v = 2 after a taken step). Stops after
// `max_iterations` steps (taken or not), or, without taking the step, when
// the step's norm is <= 1e-8 (|x| + 1e-8) or the cost changes by <= 1e-6 of
// itself, or when the gradient's max norm is <= 1e-10. A step that puts a
// point behind a camera has infinite cost (rejected). As in Ceres, a point
// behind its camera at the start stops the solve before its first step
// (SparseLmSummary::ran = false). Unlike Ceres, 5 invalid steps in a row (a
// failed factorisation or no model decrease) end the solve at the estimate
// reached (Ceres reports FAILURE and hands back the start).
//
// Deterministic: one thread, sums in the order of the observations.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "common/rigid3.h"
#include "tracker/backend/local_ba.h"
#include "tracker/pose_optimizer.h"
#include "tracker/reprojection_residual.h"

namespace dypho {

struct SparseLmOptions {
  int max_iterations = 10;            // steps, taken or rejected (Ceres's max_num_iterations), >= 0
  double function_tolerance = 1e-6;   // stop when |cost change| <= this x cost (Ceres's default)
  double parameter_tolerance = 1e-8;  // stop when |step| <= this x (|x| + this) (Ceres's default)
  double gradient_tolerance = 1e-10;  // stop when max |gradient| <= this (Ceres's default)
  double initial_radius = 1e4;        // trust region radius = 1 / LM damping at the start (Ceres's default)
};

struct SparseLmSummary {
  bool ran = false;            // false: nothing to solve, or an active observation behind its camera at the start
  double initial_cost = -1.0;  // 1/2 sum w rho(e^2) at the start / at the end; -1 when not ran (as Ceres reports)
  double final_cost = -1.0;
  int iterations = 0;  // steps taken or rejected (as Ceres's successful + unsuccessful steps)
};

// Minimises the cost over the observations i of `problem` with active[i]
// (and weight > 0), updating problem->cam_from_world (free keyframes) and
// problem->positions in place. `k` and `residuals` (chi2_mono, chi2_depth,
// huber, disparity_sigma_scale) define the cost as in SolveLocalBa.
SparseLmSummary SolveSparseLm(const ProjectionIntrinsics& k, const PoseOptimizerOptions& residuals,
                              const std::vector<char>& active, const SparseLmOptions& options, LocalBaProblem* problem);

// The residual r (r(2) = 0 without depth) of observation `o` at
// `cam_from_world` and point `x`, and its Jacobians with respect to the left
// perturbation delta of the pose (3x6) and to the point (3x3). False (and
// nothing written) when the point is behind the camera. Exposed for the
// finite-difference test.
bool BaResidualAndJacobians(const ProjectionIntrinsics& k, double disparity_sigma_scale, const LocalBaObservation& o,
                            const Rigid3d& cam_from_world, const Eigen::Vector3d& x, Eigen::Vector3d* r,
                            Eigen::Matrix<double, 3, 6>* d_pose, Eigen::Matrix3d* d_point);

}  // namespace dypho
