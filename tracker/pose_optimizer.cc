#include "tracker/pose_optimizer.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <ceres/ceres.h>

#include "common/check.h"
#include "tracker/reprojection_residual.h"

namespace dypho {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

constexpr double kMinZ = kMinProjectionZ;  // [m] a point nearer than this counts as behind the camera
constexpr double kBehindSquaredError = 1e6;  // e^2 charged to a point behind the camera

using Intrinsics = ProjectionIntrinsics;

bool HasDepth(const PoseObservation& o) { return std::isfinite(o.depth) && o.depth > 0.0; }

// Unweighted squared error of one observation at a pose (kBehindSquaredError
// when the point is not in front of the camera).
double SquaredError(const Intrinsics& k, const PoseObservation& o, const Rigid3d& cam_from_world,
                    double disparity_sigma_scale, bool* in_front) {
  const Eigen::Vector3d p = o.row_cam_from_cam * (cam_from_world * o.point_world);
  *in_front = p.z() > kMinZ;
  if (!*in_front) return kBehindSquaredError;
  Eigen::Vector3d r;
  ProjectionResidualJacobian(p, k, o.pixel, HasDepth(o), o.depth, o.sigma, disparity_sigma_scale, &r, nullptr);
  return r.squaredNorm();
}

class EigenLmProblem {
 public:
  EigenLmProblem(const Intrinsics& k, const std::vector<PoseObservation>& obs, const PoseOptimizerOptions& options)
      : k_(k), obs_(obs), options_(options) {}

  // Robust cost over `active`; with H and g non-null also the normal
  // equations of the IRLS linearisation (H = sum w rho' J^T J, g = sum w rho' J^T r).
  double Evaluate(const Rigid3d& pose, const std::vector<char>& active, Matrix6d* H, Vector6d* g) const {
    double cost = 0.0;
    if (H != nullptr) {
      H->setZero();
      g->setZero();
    }
    const Eigen::Matrix3d R = pose.rotation.toRotationMatrix();
    for (size_t i = 0; i < obs_.size(); ++i) {
      if (!active[i]) continue;
      const PoseObservation& o = obs_[i];
      if (o.weight <= 0.0) continue;
      const bool with_depth = HasDepth(o);
      const double delta2 = with_depth ? options_.chi2_depth : options_.chi2_mono;
      const Eigen::Vector3d q = R * o.point_world + pose.translation;  // in the frame's reference camera
      const Eigen::Matrix3d A = o.row_cam_from_cam.rotation.toRotationMatrix();
      const Eigen::Vector3d p = A * q + o.row_cam_from_cam.translation;  // in the camera of the row's time
      double slope = 1.0;
      if (p.z() <= kMinZ) {
        cost += o.weight * HuberOfSquared(kBehindSquaredError, delta2, options_.huber, &slope);
        continue;
      }
      Eigen::Vector3d r;
      Eigen::Matrix3d dr_dp;  // d(residual)/dP, P = (px, py, pz) in the camera
      ProjectionResidualJacobian(p, k_, o.pixel, with_depth, o.depth, o.sigma, options_.disparity_sigma_scale, &r,
                                 H != nullptr ? &dr_dp : nullptr);
      const double e2 = r.squaredNorm();
      cost += o.weight * HuberOfSquared(e2, delta2, options_.huber, &slope);
      if (H == nullptr) continue;
      // dq/d(delta) for the left perturbation Exp(delta) * pose is [I, -[q]x];
      // P = A q + a adds the factor A.
      const Eigen::Matrix<double, 3, 6> dq_dd = LeftPerturbationJacobian(q);
      // Without depth the third row of dr_dp and r(2) are zero.
      const Eigen::Matrix<double, 3, 6> J = dr_dp * A * dq_dd;
      const double w = o.weight * slope;
      H->noalias() += w * J.transpose() * J;
      g->noalias() += w * J.transpose() * r;
    }
    return cost;
  }

  // At most `max_iterations` LM iterations from *pose over `active`; sets
  // *converged when it stopped on the step or cost tolerance.
  int Run(Rigid3d* pose, const std::vector<char>& active, int max_iterations, double* lambda, bool* converged) const {
    *converged = false;
    Matrix6d H;
    Vector6d g;
    double cost = Evaluate(*pose, active, &H, &g);
    double nu = 2.0;
    int iterations = 0;
    for (int it = 0; it < max_iterations; ++it) {
      ++iterations;
      Matrix6d A = H;
      for (int d = 0; d < 6; ++d) A(d, d) += *lambda * std::clamp(H(d, d), 1e-6, 1e32);
      const Vector6d step = A.ldlt().solve(-g);
      if (!step.allFinite()) break;
      const Rigid3d candidate = Rigid3d::Exp(step) * *pose;
      const double new_cost = Evaluate(candidate, active, nullptr, nullptr);
      // Quadratic model of the cost: F + 2 g.step + step' H step.
      const double predicted = -(2.0 * g.dot(step) + step.dot(H * step));
      const double actual = cost - new_cost;
      if (actual > 0.0 && std::isfinite(new_cost)) {
        *pose = candidate;
        const double gain = predicted > 0.0 ? actual / predicted : 1.0;
        *lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * gain - 1.0, 3));
        *lambda = std::max(*lambda, 1e-12);
        nu = 2.0;
        const double previous = cost;
        cost = Evaluate(*pose, active, &H, &g);
        if (step.norm() < 1e-8 || actual < 1e-10 * previous) {
          *converged = true;
          break;
        }
      } else {
        *lambda *= nu;
        nu *= 2.0;
        if (*lambda > 1e16 || step.norm() < 1e-12) {
          *converged = true;  // no descent left at this point
          break;
        }
      }
    }
    return iterations;
  }

 private:
  const Intrinsics& k_;
  const std::vector<PoseObservation>& obs_;
  const PoseOptimizerOptions& options_;
};

// Ceres cost of one observation: 2 residuals, or 3 with depth.
template <bool kWithDepth>
struct CeresObservationCost {
  CeresObservationCost(const PoseObservation& o, const Intrinsics& k, double disparity_sigma_scale)
      : point(o.point_world), row_rotation(o.row_cam_from_cam.rotation.toRotationMatrix()),
        row_translation(o.row_cam_from_cam.translation), pixel(o.pixel), inv_depth(kWithDepth ? 1.0 / o.depth : 0.0),
        inv_s(1.0 / o.sigma), inv_sd(1.0 / (o.sigma * disparity_sigma_scale)), k(k) {}

  template <typename T>
  bool operator()(const T* rotation, const T* translation, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(rotation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(translation);
    const Eigen::Matrix<T, 3, 1> p =
        row_rotation.cast<T>() * (q * point.cast<T>() + t) + row_translation.cast<T>();
    return ProjectionResidual<kWithDepth>(p, k, pixel, inv_depth, inv_s, inv_sd, residuals);
  }

  Eigen::Vector3d point;
  Eigen::Matrix3d row_rotation;
  Eigen::Vector3d row_translation;
  Eigen::Vector2d pixel;
  double inv_depth, inv_s, inv_sd;
  Intrinsics k;
};

int RunCeres(const Intrinsics& k, const std::vector<PoseObservation>& obs, const PoseOptimizerOptions& options,
             const std::vector<char>& active, Rigid3d* pose, bool* converged) {
  *converged = true;
  Eigen::Quaterniond q = pose->rotation;
  Eigen::Vector3d t = pose->translation;
  ceres::Problem problem;
  int blocks = 0;
  for (size_t i = 0; i < obs.size(); ++i) {
    if (!active[i] || obs[i].weight <= 0.0) continue;
    const bool with_depth = HasDepth(obs[i]);
    ceres::CostFunction* cost =
        with_depth ? static_cast<ceres::CostFunction*>(
                         new ceres::AutoDiffCostFunction<CeresObservationCost<true>, 3, 4, 3>(
                             new CeresObservationCost<true>(obs[i], k, options.disparity_sigma_scale)))
                   : new ceres::AutoDiffCostFunction<CeresObservationCost<false>, 2, 4, 3>(
                         new CeresObservationCost<false>(obs[i], k, options.disparity_sigma_scale));
    ceres::LossFunction* robust =
        options.huber ? new ceres::HuberLoss(std::sqrt(with_depth ? options.chi2_depth : options.chi2_mono)) : nullptr;
    ceres::LossFunction* loss = new ceres::ScaledLoss(robust, obs[i].weight, ceres::TAKE_OWNERSHIP);
    problem.AddResidualBlock(cost, loss, q.coeffs().data(), t.data());
    ++blocks;
  }
  if (blocks == 0) return 0;
  problem.SetManifold(q.coeffs().data(), new ceres::EigenQuaternionManifold());
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = options.iterations_per_round;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  solver.function_tolerance = 1e-12;
  solver.gradient_tolerance = 1e-14;
  solver.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  *converged = summary.termination_type == ceres::CONVERGENCE;
  if (q.coeffs().allFinite() && t.allFinite()) *pose = Rigid3d(q, t);
  return summary.num_successful_steps + summary.num_unsuccessful_steps;
}

}  // namespace

bool PoseOptimizerOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  if (rounds < 1) {
    e << "rounds must be >= 1 (got " << rounds << ")";
  } else if (iterations_per_round < 1) {
    e << "iterations_per_round must be >= 1 (got " << iterations_per_round << ")";
  } else if (!(chi2_mono > 0.0) || !std::isfinite(chi2_mono)) {
    e << "chi2_mono must be > 0 (got " << chi2_mono << ")";
  } else if (!(chi2_depth > 0.0) || !std::isfinite(chi2_depth)) {
    e << "chi2_depth must be > 0 (got " << chi2_depth << ")";
  } else if (!(virtual_baseline > 0.0) || !std::isfinite(virtual_baseline)) {
    e << "virtual_baseline must be > 0 m (got " << virtual_baseline << ")";
  } else if (!(disparity_sigma_scale > 0.0) || !std::isfinite(disparity_sigma_scale)) {
    e << "disparity_sigma_scale must be > 0 (got " << disparity_sigma_scale << ")";
  } else if (min_inliers < 3) {
    e << "min_inliers must be >= 3 (got " << min_inliers << ")";
  } else {
    return true;
  }
  if (error != nullptr) *error = "PoseOptimizerOptions." + e.str();
  return false;
}

PoseOptimizerResult OptimizePose(const Camera& camera, const std::vector<PoseObservation>& observations,
                                 const Rigid3d& initial_cam_from_world, const PoseOptimizerOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  DYPHO_CHECK_INPUT(camera.fx > 0 && camera.fy > 0 && std::isfinite(camera.cx) && std::isfinite(camera.cy))
      << "OptimizePose: camera intrinsics must be finite with fx, fy > 0";
  DYPHO_CHECK_INPUT(initial_cam_from_world.rotation.coeffs().allFinite() &&
                    initial_cam_from_world.translation.allFinite())
      << "OptimizePose: the initial pose is not finite";
  for (size_t i = 0; i < observations.size(); ++i) {
    const PoseObservation& o = observations[i];
    DYPHO_CHECK_INPUT(o.point_world.allFinite() && o.pixel.allFinite())
        << "OptimizePose: observation " << i << " has a non-finite point or pixel";
    DYPHO_CHECK_INPUT(o.sigma > 0.0 && std::isfinite(o.sigma))
        << "OptimizePose: observation " << i << " has sigma " << o.sigma << " (must be > 0)";
    DYPHO_CHECK_INPUT(std::isfinite(o.weight) && o.weight >= 0.0 && o.weight <= 1.0)
        << "OptimizePose: observation " << i << " has weight " << o.weight << " (must be in [0, 1])";
  }

  const Intrinsics k{camera.fx, camera.fy, camera.cx, camera.cy, camera.fx * options.virtual_baseline};
  PoseOptimizerResult result;
  result.cam_from_world = initial_cam_from_world;
  const size_t n = observations.size();
  result.inliers.assign(n, 1);
  result.num_inliers = static_cast<int>(n);
  if (static_cast<int>(n) < options.min_inliers) {
    result.inliers.assign(n, 0);
    result.num_inliers = 0;
    return result;
  }

  EigenLmProblem lm(k, observations, options);
  Rigid3d pose = initial_cam_from_world;
  double lambda = 1e-4;
  std::vector<char> active(n, 1);
  for (int round = 0; round < options.rounds; ++round) {
    bool converged = false;
    if (options.solver == PoseSolver::kEigenLm) {
      result.iterations += lm.Run(&pose, active, options.iterations_per_round, &lambda, &converged);
    } else {
      result.iterations += RunCeres(k, observations, options, active, &pose, &converged);
    }
    // Classify every observation at the new pose.
    int inliers = 0;
    bool changed = false;
    for (size_t i = 0; i < n; ++i) {
      bool in_front = false;
      const double e2 = SquaredError(k, observations[i], pose, options.disparity_sigma_scale, &in_front);
      const double chi2 = HasDepth(observations[i]) ? options.chi2_depth : options.chi2_mono;
      const char inlier = in_front && e2 <= chi2;
      changed |= inlier != active[i];
      active[i] = inlier;
      inliers += inlier;
    }
    result.num_inliers = inliers;
    // Done when too few remain, or when the inliers did not change (the
    // next round would start from the optimum of the same problem).
    if (inliers < options.min_inliers || (!changed && converged)) break;
  }
  result.inliers = active;
  result.cam_from_world = pose;
  result.cost = lm.Evaluate(pose, active, nullptr, nullptr);
  result.usable = result.num_inliers >= options.min_inliers && pose.rotation.coeffs().allFinite() &&
                  pose.translation.allFinite();
  return result;
}

}  // namespace dypho
