#include "tracker/backend/sparse_lm.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>

namespace dypho {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix63d = Eigen::Matrix<double, 6, 3>;
using Matrix36d = Eigen::Matrix<double, 3, 6>;

// Ceres's defaults for LEVENBERG_MARQUARDT (ceres::Solver::Options).
constexpr double kMinDiagonal = 1e-6;          // min_lm_diagonal
constexpr double kMaxDiagonal = 1e32;          // max_lm_diagonal
constexpr double kMaxRadius = 1e16;            // max_trust_region_radius
constexpr double kMinRadius = 1e-32;           // min_trust_region_radius
constexpr double kMinRelativeDecrease = 1e-3;  // min_relative_decrease
constexpr int kMaxInvalidSteps = 5;            // max_num_consecutive_invalid_steps

// The point in the camera that read the observation's row: p = A q + a with
// q = R x + t (cam_from_world = (R, t), row_cam_from_cam = (A, a)).
struct Projected {
  Eigen::Vector3d q, p;
};

Projected Project(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, const Eigen::Matrix3d& A,
                  const Eigen::Vector3d& a, const Eigen::Vector3d& x) {
  Projected out;
  out.q = R * x + t;
  out.p = A * out.q + a;
  return out;
}

// r, d r / d delta (pose, left perturbation) and d r / d x at a point in
// front of the camera: d p / d delta = A [I, -[q]x], d p / d x = A R.
void Jacobians(const ProjectionIntrinsics& k, double disparity_sigma_scale, const LocalBaObservation& o,
               bool with_depth, const Eigen::Matrix3d& R, const Eigen::Matrix3d& A, const Projected& pq,
               Eigen::Vector3d* r, Matrix36d* d_pose, Eigen::Matrix3d* d_point) {
  Eigen::Matrix3d dr_dp;
  ProjectionResidualJacobian(pq.p, k, o.pixel, with_depth, o.depth, o.sigma, disparity_sigma_scale, r, &dr_dp);
  const Eigen::Matrix3d B = dr_dp * A;
  d_point->noalias() = B * R;
  if (d_pose != nullptr) d_pose->noalias() = B * LeftPerturbationJacobian(pq.q);
}

// One active observation and what stays fixed during the solve.
struct Term {
  const LocalBaObservation* o = nullptr;
  int pose = -1;    // index into the problem's keyframes
  int camera = -1;  // block of the free pose in the reduced system; -1 = fixed
  int point = -1;   // index into the solved points
  bool with_depth = false;
  double delta2 = 0.0;  // Huber delta^2 = chi2 of the observation's kind
  Eigen::Matrix3d row_rotation;
};

class SparseLm {
 public:
  SparseLm(const ProjectionIntrinsics& k, const PoseOptimizerOptions& residuals, const std::vector<char>& active,
           LocalBaProblem* problem);
  SparseLmSummary Run(const SparseLmOptions& options);

 private:
  // Cost at `poses` and `points`; false when a term is behind its camera or
  // the cost is not finite.
  bool Cost(const std::vector<Rigid3d>& poses, const std::vector<Eigen::Vector3d>& points, double* cost) const;
  // The blocks of H and g at the current estimate, and the LM diagonal.
  void Linearize();
  // The step for damping 1 / radius into step_camera_, step_point_ and the
  // model's cost decrease into model_decrease_; false when the linear solve
  // fails or the model does not decrease (Ceres's invalid step).
  bool ComputeStep(double radius);

  const ProjectionIntrinsics k_;
  const PoseOptimizerOptions& residuals_;
  LocalBaProblem* problem_;
  std::vector<Term> terms_;
  std::vector<int> camera_pose_;                // per camera block: the pose index
  std::vector<int> point_source_;               // per solved point: the index into problem->positions
  std::vector<int> point_start_, point_terms_;  // per point, its terms (CSR, in observation order)
  std::vector<Rigid3d> poses_;                  // current estimate: every pose of the problem
  std::vector<Eigen::Vector3d> points_;         // current estimate: the solved points
  double cost_ = 0.0;
  // The linearisation at the current estimate.
  std::vector<Matrix6d> u_;          // per camera: sum w J_c^T J_c
  std::vector<Vector6d> gc_;         // per camera: sum w J_c^T r
  std::vector<Eigen::Matrix3d> v_;   // per point: sum w J_x^T J_x
  std::vector<Eigen::Vector3d> gx_;  // per point: sum w J_x^T r
  std::vector<Matrix63d> w_;         // per term with a free camera: w J_c^T J_x
  std::vector<Vector6d> diag_camera_;
  std::vector<Eigen::Vector3d> diag_point_;
  double gradient_max_norm_ = 0.0;
  // The step.
  std::vector<Eigen::Matrix3d> v_inv_;
  Eigen::MatrixXd reduced_;
  Eigen::VectorXd rhs_, step_camera_;
  std::vector<Eigen::Vector3d> step_point_;
  double model_decrease_ = 0.0;
};

SparseLm::SparseLm(const ProjectionIntrinsics& k, const PoseOptimizerOptions& residuals,
                   const std::vector<char>& active, LocalBaProblem* problem)
    : k_(k), residuals_(residuals), problem_(problem), poses_(problem->cam_from_world) {
  const size_t n_poses = problem->keyframes.size();
  std::vector<int> camera_of(n_poses, -2), point_of(problem->positions.size(), -1);  // -2 = not seen yet
  for (size_t i = 0; i < problem->observations.size(); ++i) {
    const LocalBaObservation& o = problem->observations[i];
    if (!active[i] || !(o.weight > 0.0)) continue;
    Term t;
    t.o = &o;
    t.pose = o.pose;
    if (camera_of[o.pose] == -2) {
      camera_of[o.pose] = problem->fixed[o.pose] ? -1 : static_cast<int>(camera_pose_.size());
      if (!problem->fixed[o.pose]) camera_pose_.push_back(o.pose);
    }
    t.camera = camera_of[o.pose];
    if (point_of[o.point] < 0) {
      point_of[o.point] = static_cast<int>(point_source_.size());
      point_source_.push_back(o.point);
      points_.push_back(problem->positions[o.point]);
    }
    t.point = point_of[o.point];
    t.with_depth = o.has_depth();
    t.delta2 = t.with_depth ? residuals.chi2_depth : residuals.chi2_mono;
    t.row_rotation = o.row_cam_from_cam.rotation.toRotationMatrix();
    terms_.push_back(t);
  }
  // Terms per point (counting sort: observation order within a point).
  const size_t n_points = points_.size();
  point_start_.assign(n_points + 1, 0);
  for (const Term& t : terms_) ++point_start_[t.point + 1];
  for (size_t j = 0; j < n_points; ++j) point_start_[j + 1] += point_start_[j];
  point_terms_.resize(terms_.size());
  std::vector<int> fill(point_start_.begin(), point_start_.end() - 1);
  for (size_t i = 0; i < terms_.size(); ++i) point_terms_[fill[terms_[i].point]++] = static_cast<int>(i);
}

bool SparseLm::Cost(const std::vector<Rigid3d>& poses, const std::vector<Eigen::Vector3d>& points, double* cost) const {
  std::vector<Eigen::Matrix3d> rotations(poses.size());
  for (size_t p = 0; p < poses.size(); ++p) rotations[p] = poses[p].rotation.toRotationMatrix();
  double sum = 0.0;
  for (const Term& t : terms_) {
    const LocalBaObservation& o = *t.o;
    const Projected pq = Project(rotations[t.pose], poses[t.pose].translation, t.row_rotation,
                                 o.row_cam_from_cam.translation, points[t.point]);
    if (!(pq.p.z() > kMinProjectionZ)) return false;
    Eigen::Vector3d r;
    ProjectionResidualJacobian(pq.p, k_, o.pixel, t.with_depth, o.depth, o.sigma, residuals_.disparity_sigma_scale, &r,
                               nullptr);
    double slope = 1.0;
    sum += o.weight * HuberOfSquared(r.squaredNorm(), t.delta2, residuals_.huber, &slope);
  }
  *cost = 0.5 * sum;
  return std::isfinite(*cost);
}

void SparseLm::Linearize() {
  const size_t n_cameras = camera_pose_.size(), n_points = points_.size();
  u_.assign(n_cameras, Matrix6d::Zero());
  gc_.assign(n_cameras, Vector6d::Zero());
  v_.assign(n_points, Eigen::Matrix3d::Zero());
  gx_.assign(n_points, Eigen::Vector3d::Zero());
  w_.resize(terms_.size());
  std::vector<Eigen::Matrix3d> rotations(poses_.size());
  for (size_t p = 0; p < poses_.size(); ++p) rotations[p] = poses_[p].rotation.toRotationMatrix();
  for (size_t i = 0; i < terms_.size(); ++i) {
    const Term& t = terms_[i];
    const LocalBaObservation& o = *t.o;
    const Eigen::Matrix3d& R = rotations[t.pose];
    const Projected pq =
        Project(R, poses_[t.pose].translation, t.row_rotation, o.row_cam_from_cam.translation, points_[t.point]);
    // In front: the estimate's cost was finite.
    Eigen::Vector3d r;
    Matrix36d jc;
    Eigen::Matrix3d jx;
    Jacobians(k_, residuals_.disparity_sigma_scale, o, t.with_depth, R, t.row_rotation, pq, &r,
              t.camera >= 0 ? &jc : nullptr, &jx);
    double slope = 1.0;
    HuberOfSquared(r.squaredNorm(), t.delta2, residuals_.huber, &slope);
    const double w = o.weight * slope;
    const Eigen::Matrix3d wjx_t = w * jx.transpose();
    v_[t.point].noalias() += wjx_t * jx;
    gx_[t.point].noalias() += wjx_t * r;
    if (t.camera < 0) continue;
    const Matrix63d wjc_t = w * jc.transpose();
    u_[t.camera].noalias() += wjc_t * jc;
    gc_[t.camera].noalias() += wjc_t * r;
    w_[i].noalias() = wjc_t * jx;
  }
  gradient_max_norm_ = 0.0;
  diag_camera_.resize(n_cameras);
  diag_point_.resize(n_points);
  for (size_t c = 0; c < n_cameras; ++c) {
    gradient_max_norm_ = std::max(gradient_max_norm_, gc_[c].lpNorm<Eigen::Infinity>());
    diag_camera_[c] = u_[c].diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
  }
  for (size_t j = 0; j < n_points; ++j) {
    gradient_max_norm_ = std::max(gradient_max_norm_, gx_[j].lpNorm<Eigen::Infinity>());
    diag_point_[j] = v_[j].diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
  }
}

bool SparseLm::ComputeStep(double radius) {
  const double lambda = 1.0 / radius;
  const int n_cameras = static_cast<int>(camera_pose_.size());
  const size_t n_points = points_.size();
  // Reduced camera system S dc = b: S = U* - sum W V*^-1 W^T, b = -gc + sum
  // W V*^-1 gx (upper triangle of S only; LDLT reads that).
  reduced_.setZero(6 * n_cameras, 6 * n_cameras);
  rhs_.resize(6 * n_cameras);
  for (int c = 0; c < n_cameras; ++c) {
    reduced_.block<6, 6>(6 * c, 6 * c) = u_[c];
    reduced_.block<6, 6>(6 * c, 6 * c).diagonal() += lambda * diag_camera_[c];
    rhs_.segment<6>(6 * c) = -gc_[c];
  }
  v_inv_.resize(n_points);
  for (size_t j = 0; j < n_points; ++j) {
    Eigen::Matrix3d damped = v_[j];
    damped.diagonal() += lambda * diag_point_[j];
    v_inv_[j] = damped.inverse();
    for (int a = point_start_[j]; a < point_start_[j + 1]; ++a) {
      const int ia = point_terms_[a], ca = terms_[ia].camera;
      if (ca < 0) continue;
      const Matrix63d t = w_[ia] * v_inv_[j];
      rhs_.segment<6>(6 * ca).noalias() += t * gx_[j];
      for (int b = point_start_[j]; b < point_start_[j + 1]; ++b) {
        const int ib = point_terms_[b], cb = terms_[ib].camera;
        if (cb < ca) continue;  // also skips fixed cameras (-1)
        reduced_.block<6, 6>(6 * ca, 6 * cb).noalias() -= t * w_[ib].transpose();
      }
    }
  }
  if (n_cameras > 0) {
    const Eigen::LDLT<Eigen::MatrixXd, Eigen::Upper> ldlt(reduced_);
    if (ldlt.info() != Eigen::Success) return false;
    step_camera_ = ldlt.solve(rhs_);
  } else {
    step_camera_.resize(0);
  }
  if (!step_camera_.allFinite()) return false;
  // Back-substitution: dx = V*^-1 (-gx - sum W^T dc); the model decrease
  // -(g . d + d^T H d / 2) from the undamped blocks.
  step_point_.resize(n_points);
  double g_dot_d = 0.0, d_h_d = 0.0;
  for (int c = 0; c < n_cameras; ++c) {
    const Vector6d dc = step_camera_.segment<6>(6 * c);
    g_dot_d += gc_[c].dot(dc);
    d_h_d += dc.dot(u_[c] * dc);
  }
  for (size_t j = 0; j < n_points; ++j) {
    Eigen::Vector3d b = -gx_[j];
    for (int a = point_start_[j]; a < point_start_[j + 1]; ++a) {
      const int ia = point_terms_[a], ca = terms_[ia].camera;
      if (ca >= 0) b.noalias() -= w_[ia].transpose() * step_camera_.segment<6>(6 * ca);
    }
    const Eigen::Vector3d dx = v_inv_[j] * b;
    step_point_[j] = dx;
    g_dot_d += gx_[j].dot(dx);
    d_h_d += dx.dot(v_[j] * dx);
    for (int a = point_start_[j]; a < point_start_[j + 1]; ++a) {
      const int ia = point_terms_[a], ca = terms_[ia].camera;
      if (ca >= 0) d_h_d += 2.0 * step_camera_.segment<6>(6 * ca).dot(w_[ia] * dx);
    }
  }
  model_decrease_ = -(g_dot_d + 0.5 * d_h_d);
  return std::isfinite(model_decrease_) && model_decrease_ > 0.0;
}

SparseLmSummary SparseLm::Run(const SparseLmOptions& options) {
  SparseLmSummary summary;
  if (terms_.empty() || !Cost(poses_, points_, &cost_)) return summary;  // as Ceres: no step at all
  summary.ran = true;
  summary.initial_cost = cost_;
  Linearize();
  double radius = options.initial_radius, decrease_factor = 2.0;
  int invalid_steps = 0, steps = 0;
  bool taken = true;  // the start counts as a taken step for the gradient test (as Ceres's iteration 0)
  std::vector<Rigid3d> candidate_poses;
  std::vector<Eigen::Vector3d> candidate_points;
  auto reject = [&]() {
    radius /= decrease_factor;
    decrease_factor *= 2.0;
  };
  for (;;) {
    // Ceres's checks at the end of an iteration.
    if (steps >= options.max_iterations) break;
    if (taken && gradient_max_norm_ <= options.gradient_tolerance) break;
    if (radius <= kMinRadius) break;
    taken = false;
    if (!ComputeStep(radius)) {
      if (++invalid_steps >= kMaxInvalidSteps) break;
      ++steps;
      reject();
      continue;
    }
    invalid_steps = 0;
    // The candidate, and the step's and the estimate's norms in the
    // parameters' own space (quaternion coefficients, translations, points).
    candidate_poses = poses_;
    candidate_points = points_;
    double x_norm2 = 0.0, step_norm2 = 0.0;
    for (size_t c = 0; c < camera_pose_.size(); ++c) {
      const int p = camera_pose_[c];
      candidate_poses[p] = Rigid3d::Exp(step_camera_.segment<6>(6 * c)) * poses_[p];
      x_norm2 += poses_[p].rotation.coeffs().squaredNorm() + poses_[p].translation.squaredNorm();
      step_norm2 += (candidate_poses[p].rotation.coeffs() - poses_[p].rotation.coeffs()).squaredNorm() +
                    (candidate_poses[p].translation - poses_[p].translation).squaredNorm();
    }
    for (size_t j = 0; j < points_.size(); ++j) {
      candidate_points[j] += step_point_[j];
      x_norm2 += points_[j].squaredNorm();
      step_norm2 += step_point_[j].squaredNorm();
    }
    double candidate_cost = std::numeric_limits<double>::infinity();
    if (!Cost(candidate_poses, candidate_points, &candidate_cost)) {
      candidate_cost = std::numeric_limits<double>::infinity();  // behind a camera: rejected
    }
    // Converged (the step is not taken, as in Ceres).
    const double tol = options.parameter_tolerance;
    if (std::sqrt(step_norm2) <= tol * (std::sqrt(x_norm2) + tol)) break;
    if (std::abs(cost_ - candidate_cost) <= options.function_tolerance * cost_) break;
    ++steps;
    const double relative_decrease = (cost_ - candidate_cost) / model_decrease_;
    if (relative_decrease > kMinRelativeDecrease) {
      poses_.swap(candidate_poses);
      points_.swap(candidate_points);
      cost_ = candidate_cost;
      Linearize();
      radius /= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * relative_decrease - 1.0, 3));
      radius = std::min(radius, kMaxRadius);
      decrease_factor = 2.0;
      taken = true;
    } else {
      reject();
    }
  }
  summary.iterations = steps;
  summary.final_cost = cost_;
  for (int p : camera_pose_) problem_->cam_from_world[p] = poses_[p];
  for (size_t j = 0; j < points_.size(); ++j) problem_->positions[point_source_[j]] = points_[j];
  return summary;
}

}  // namespace

SparseLmSummary SolveSparseLm(const ProjectionIntrinsics& k, const PoseOptimizerOptions& residuals,
                              const std::vector<char>& active, const SparseLmOptions& options,
                              LocalBaProblem* problem) {
  SparseLm lm(k, residuals, active, problem);
  return lm.Run(options);
}

bool BaResidualAndJacobians(const ProjectionIntrinsics& k, double disparity_sigma_scale, const LocalBaObservation& o,
                            const Rigid3d& cam_from_world, const Eigen::Vector3d& x, Eigen::Vector3d* r,
                            Matrix36d* d_pose, Eigen::Matrix3d* d_point) {
  const Eigen::Matrix3d R = cam_from_world.rotation.toRotationMatrix();
  const Eigen::Matrix3d A = o.row_cam_from_cam.rotation.toRotationMatrix();
  const Projected pq = Project(R, cam_from_world.translation, A, o.row_cam_from_cam.translation, x);
  if (!(pq.p.z() > kMinProjectionZ)) return false;
  Jacobians(k, disparity_sigma_scale, o, o.has_depth(), R, A, pq, r, d_pose, d_point);
  return true;
}

}  // namespace dypho
