#include "tracker/backend/local_ba.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include <ceres/ceres.h>

#include "tracker/backend/covisibility.h"
#include "tracker/backend/sparse_lm.h"
#include "tracker/reprojection_residual.h"

namespace dypho {
namespace {


using Intrinsics = ProjectionIntrinsics;

// One observation: 2 residuals, or 3 with depth; parameters: the keyframe's
// rotation (Eigen quaternion coefficients x, y, z, w), its translation and
// the point.
template <bool kWithDepth>
struct BaCost {
  BaCost(const LocalBaObservation& o, const Intrinsics& k, double disparity_sigma_scale)
      : row_rotation(o.row_cam_from_cam.rotation.toRotationMatrix()),
        row_translation(o.row_cam_from_cam.translation), pixel(o.pixel),
        inv_depth(kWithDepth ? 1.0 / o.depth : 0.0), inv_s(1.0 / o.sigma),
        inv_sd(1.0 / (o.sigma * disparity_sigma_scale)), k(k) {}

  template <typename T>
  bool operator()(const T* rotation, const T* translation, const T* point, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(rotation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(translation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> x(point);
    const Eigen::Matrix<T, 3, 1> p = row_rotation.cast<T>() * (q * x + t) + row_translation.cast<T>();
    return ProjectionResidual<kWithDepth>(p, k, pixel, inv_depth, inv_s, inv_sd, residuals);
  }

  Eigen::Matrix3d row_rotation;
  Eigen::Vector3d row_translation;
  Eigen::Vector2d pixel;
  double inv_depth, inv_s, inv_sd;
  Intrinsics k;
};

// Unweighted e^2 of an observation (infinite when behind the camera).
double SquaredError(const Intrinsics& k, const LocalBaObservation& o, const Rigid3d& cam_from_world,
                    const Eigen::Vector3d& x, double disparity_sigma_scale) {
  const Eigen::Vector3d p = o.row_cam_from_cam * (cam_from_world * x);
  if (p.z() <= kMinProjectionZ) return INFINITY;
  Eigen::Vector3d r;
  ProjectionResidualJacobian(p, k, o.pixel, o.has_depth(), o.depth, o.sigma, disparity_sigma_scale, &r, nullptr);
  return r.squaredNorm();
}

}  // namespace

bool LocalBaOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  if (max_keyframes < 1) {
    e << "max_keyframes must be >= 1 (got " << max_keyframes << ")";
  } else if (fixed_lag < 0 || fixed_lag > 1000) {
    e << "fixed_lag must be in 0..1000 (got " << fixed_lag << ")";
  } else if (min_shared < 1) {
    e << "min_shared must be >= 1 (got " << min_shared << ")";
  } else if (max_fixed_keyframes < 1) {
    e << "max_fixed_keyframes must be >= 1 (got " << max_fixed_keyframes << ")";
  } else if (first_iterations < 1) {
    e << "first_iterations must be >= 1 (got " << first_iterations << ")";
  } else if (iterations < 0) {
    e << "iterations must be >= 0 (got " << iterations << ")";
  } else if (solver != "ceres" && solver != "eigen") {
    e << "solver must be \"ceres\" or \"eigen\" (got \"" << solver << "\")";
  } else if (!(disparity_sigma_scale >= 0.0) || !std::isfinite(disparity_sigma_scale)) {
    e << "disparity_sigma_scale must be >= 0 (got " << disparity_sigma_scale << ")";
  } else {
    return true;
  }
  if (error != nullptr) *error = "LocalBaOptions." + e.str();
  return false;
}

int LocalBaProblem::num_free_keyframes() const {
  return static_cast<int>(std::count(fixed.begin(), fixed.end(), 0));
}

namespace {

// The observations of the problem's points by its keyframes, in point order
// then keyframe order.
void AddObservations(const SparseMap& map, const std::unordered_map<int, int>& pose_index, const Camera& camera,
                     double scale_factor, double readout, LocalBaProblem* problem) {
  for (size_t j = 0; j < problem->points.size(); ++j) {
    const MapPoint& mp = map.points[problem->points[j]];
    for (size_t o = 0; o < mp.keyframes.size(); ++o) {
      const auto it = pose_index.find(mp.keyframes[o]);
      if (it == pose_index.end()) continue;
      const Keyframe& k = map.keyframes[mp.keyframes[o]];
      const int f = mp.features[o];
      LocalBaObservation obs;
      obs.pose = it->second;
      obs.point = static_cast<int>(j);
      obs.feature = f;
      obs.pixel = Eigen::Vector2d(k.points[f].x, k.points[f].y);
      obs.depth = k.depths[f];
      obs.sigma = std::pow(scale_factor, k.levels[f]);
      obs.weight = k.weights[f];
      if (readout > 0.0 && !k.twist.isZero()) {
        const double tau = readout * (k.rows[f] / std::max(1, camera.height - 1) - 0.5);
        obs.row_cam_from_cam = Rigid3d::Exp(k.twist * tau);
      }
      problem->observations.push_back(obs);
    }
  }
}

}  // namespace

LocalBaProblem BuildLocalBaProblem(const SparseMap& map, int kf, const LocalBaOptions& options, const Camera& camera,
                                   double scale_factor, double readout) {
  LocalBaProblem problem;
  problem.keyframe = kf;
  // 1. The local keyframes: the new one and its most covisible ones.
  std::vector<int> local = {kf};
  for (const auto& [other, shared] : CovisibleKeyframes(map, kf, options.min_shared)) {
    if (static_cast<int>(local.size()) > options.max_keyframes) break;
    local.push_back(other);
  }
  std::unordered_map<int, int> pose_index;
  for (int k : local) {
    pose_index[k] = static_cast<int>(problem.keyframes.size());
    problem.keyframes.push_back(k);
    problem.cam_from_world.push_back(map.keyframes[k].cam_from_world);
    problem.fixed.push_back(k == 0);  // the first keyframe holds the gauge
  }
  // 2. The points they see.
  std::unordered_map<long, int> point_index;
  for (int k : local) {
    for (long id : map.keyframes[k].map_points) {
      if (id < 0 || map.points[id].bad || point_index.count(id)) continue;
      point_index[id] = static_cast<int>(problem.points.size());
      problem.points.push_back(id);
      problem.positions.push_back(map.points[id].position);
    }
  }
  // 3. The other keyframes that see them, fixed (most shared first).
  std::unordered_map<int, int> shared;
  for (long id : problem.points) {
    const MapPoint& mp = map.points[id];
    for (int k : mp.keyframes)
      if (!pose_index.count(k) && !map.keyframes[k].bad) ++shared[k];
  }
  std::vector<std::pair<int, int>> others(shared.begin(), shared.end());
  std::sort(others.begin(), others.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  if (static_cast<int>(others.size()) > options.max_fixed_keyframes) others.resize(options.max_fixed_keyframes);
  std::sort(others.begin(), others.end());  // by id: the same problem whatever the hash order
  for (const auto& [k, n] : others) {
    pose_index[k] = static_cast<int>(problem.keyframes.size());
    problem.keyframes.push_back(k);
    problem.cam_from_world.push_back(map.keyframes[k].cam_from_world);
    problem.fixed.push_back(1);
  }
  // No fixed keyframe (the first one was culled or is not covisible): the
  // oldest local keyframe holds the gauge.
  if (problem.num_free_keyframes() == static_cast<int>(problem.keyframes.size())) {
    const auto oldest = std::min_element(problem.keyframes.begin(), problem.keyframes.end());
    problem.fixed[oldest - problem.keyframes.begin()] = 1;
  }
  // 4. The observations, in point order then keyframe order.
  AddObservations(map, pose_index, camera, scale_factor, readout, &problem);
  return problem;
}

LocalBaProblem BuildGlobalBaProblem(const SparseMap& map, int fixed_keyframe, const Camera& camera,
                                    double scale_factor, double readout) {
  LocalBaProblem problem;
  problem.keyframe = fixed_keyframe;
  std::unordered_map<int, int> pose_index;
  for (size_t k = 0; k < map.keyframes.size(); ++k) {
    if (map.keyframes[k].bad) continue;
    pose_index[static_cast<int>(k)] = static_cast<int>(problem.keyframes.size());
    problem.keyframes.push_back(static_cast<int>(k));
    problem.cam_from_world.push_back(map.keyframes[k].cam_from_world);
    problem.fixed.push_back(static_cast<int>(k) == fixed_keyframe);
  }
  for (size_t id = 0; id < map.points.size(); ++id) {
    if (map.points[id].bad) continue;
    problem.points.push_back(static_cast<long>(id));
    problem.positions.push_back(map.points[id].position);
  }
  AddObservations(map, pose_index, camera, scale_factor, readout, &problem);
  return problem;
}

LocalBaSolution SolveLocalBa(const Camera& camera, LocalBaProblem problem, const LocalBaOptions& options,
                             const PoseOptimizerOptions& tracking_residuals) {
  const auto t0 = std::chrono::steady_clock::now();
  PoseOptimizerOptions residuals = tracking_residuals;
  if (options.disparity_sigma_scale > 0.0) residuals.disparity_sigma_scale = options.disparity_sigma_scale;
  LocalBaSolution solution;
  const Intrinsics k{camera.fx, camera.fy, camera.cx, camera.cy, camera.fx * residuals.virtual_baseline};
  const size_t n_obs = problem.observations.size();
  solution.outlier.assign(n_obs, 0);
  if (problem.num_free_keyframes() == 0 || n_obs == 0) {
    solution.problem = std::move(problem);
    return solution;
  }
  // Parameter blocks: quaternion coefficients (4) and translation (3) per
  // keyframe, in one buffer, and the points (contiguous in `positions`).
  // Ceres orders the blocks of an elimination group by address: with one
  // buffer per kind that order is the index order, so the solve is the same
  // on every run and thread (separate allocations made it depend on where
  // the allocator put them, changing the last bits of the result).
  const size_t n_poses = problem.keyframes.size();
  std::vector<double> pose_buffer(7 * n_poses);
  for (size_t p = 0; p < n_poses; ++p) {
    Eigen::Map<Eigen::Vector4d> q(&pose_buffer[7 * p]);
    Eigen::Map<Eigen::Vector3d> t(&pose_buffer[7 * p + 4]);
    q = problem.cam_from_world[p].rotation.coeffs();
    t = problem.cam_from_world[p].translation;
  }
  auto rotation = [&](size_t p) { return &pose_buffer[7 * p]; };
  auto translation = [&](size_t p) { return &pose_buffer[7 * p + 4]; };
  std::vector<Eigen::Vector3d>& positions = problem.positions;
  // The eigen solver works on `problem` itself.
  const bool eigen = options.solver == "eigen";
  auto pose_of = [&](int i) {
    if (eigen) return problem.cam_from_world[i];
    return Rigid3d(Eigen::Quaterniond(rotation(i)), Eigen::Map<const Eigen::Vector3d>(translation(i)));
  };
  auto chi2 = [&](const LocalBaObservation& o) { return o.has_depth() ? residuals.chi2_depth : residuals.chi2_mono; };
  auto classify = [&]() {
    for (size_t i = 0; i < n_obs; ++i) {
      const LocalBaObservation& o = problem.observations[i];
      const double e2 = SquaredError(k, o, pose_of(o.pose), positions[o.point], residuals.disparity_sigma_scale);
      solution.outlier[i] = !(e2 <= chi2(o));
    }
  };

  bool first = true;
  for (int pass = 0; pass < 2; ++pass) {
    const int iterations = pass == 0 ? options.first_iterations : options.iterations;
    if (iterations == 0) break;
    if (eigen) {
      std::vector<char> active(n_obs, 0);
      bool any = false;
      for (size_t i = 0; i < n_obs; ++i) {
        active[i] = problem.observations[i].weight > 0.0 && !solution.outlier[i];
        any = any || active[i];
      }
      if (!any) break;
      SparseLmOptions lm;
      lm.max_iterations = iterations;
      const SparseLmSummary summary = SolveSparseLm(k, residuals, active, lm, &problem);
      if (first) solution.initial_cost = summary.initial_cost;
      first = false;
      solution.final_cost = summary.final_cost;
      solution.iterations += summary.iterations;
      classify();
      continue;
    }
    ceres::Problem ceres_problem;
    std::vector<char> used_pose(problem.keyframes.size(), 0), used_point(positions.size(), 0);
    int blocks = 0;
    for (size_t i = 0; i < n_obs; ++i) {
      const LocalBaObservation& o = problem.observations[i];
      if (o.weight <= 0.0 || solution.outlier[i]) continue;
      const bool with_depth = o.has_depth();
      ceres::CostFunction* cost =
          with_depth ? static_cast<ceres::CostFunction*>(new ceres::AutoDiffCostFunction<BaCost<true>, 3, 4, 3, 3>(
                           new BaCost<true>(o, k, residuals.disparity_sigma_scale)))
                     : new ceres::AutoDiffCostFunction<BaCost<false>, 2, 4, 3, 3>(
                           new BaCost<false>(o, k, residuals.disparity_sigma_scale));
      ceres::LossFunction* robust = residuals.huber ? new ceres::HuberLoss(std::sqrt(chi2(o))) : nullptr;
      ceres::LossFunction* loss = new ceres::ScaledLoss(robust, o.weight, ceres::TAKE_OWNERSHIP);
      ceres_problem.AddResidualBlock(cost, loss, rotation(o.pose), translation(o.pose), positions[o.point].data());
      used_pose[o.pose] = used_point[o.point] = 1;
      ++blocks;
    }
    if (blocks == 0) break;
    for (size_t p = 0; p < problem.keyframes.size(); ++p) {
      if (!used_pose[p]) continue;
      ceres_problem.SetManifold(rotation(p), new ceres::EigenQuaternionManifold());
      if (problem.fixed[p]) {
        ceres_problem.SetParameterBlockConstant(rotation(p));
        ceres_problem.SetParameterBlockConstant(translation(p));
      }
    }
    // Schur ordering: points first, then the poses.
    auto* ordering = new ceres::ParameterBlockOrdering;
    for (size_t j = 0; j < positions.size(); ++j)
      if (used_point[j]) ordering->AddElementToGroup(positions[j].data(), 0);
    for (size_t p = 0; p < problem.keyframes.size(); ++p) {
      if (!used_pose[p]) continue;
      ordering->AddElementToGroup(rotation(p), 1);
      ordering->AddElementToGroup(translation(p), 1);
    }
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_SCHUR;
    solver.linear_solver_ordering.reset(ordering);
    solver.max_num_iterations = iterations;
    solver.num_threads = 1;  // deterministic
    solver.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &ceres_problem, &summary);
    if (first) solution.initial_cost = summary.initial_cost;
    first = false;
    solution.final_cost = summary.final_cost;
    solution.iterations += summary.num_successful_steps + summary.num_unsuccessful_steps;
    classify();
  }
  // Hand back normalised quaternions; a non-finite result is not usable.
  bool finite = true;
  for (size_t p = 0; p < problem.keyframes.size(); ++p) {
    if (eigen) {
      const Rigid3d& pose = problem.cam_from_world[p];
      finite = finite && pose.rotation.coeffs().allFinite() && pose.translation.allFinite();
      continue;
    }
    const Eigen::Map<const Eigen::Vector4d> q(rotation(p));
    const Eigen::Map<const Eigen::Vector3d> t(translation(p));
    finite = finite && q.allFinite() && t.allFinite() && q.norm() > 0.0;
    if (finite) problem.cam_from_world[p] = pose_of(static_cast<int>(p));
  }
  for (const Eigen::Vector3d& x : positions) finite = finite && x.allFinite();
  solution.usable = finite && !first;
  solution.problem = std::move(problem);
  solution.solve_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return solution;
}

LocalBaApplied ApplyLocalBa(const LocalBaSolution& solution, SparseMap* map) {
  LocalBaApplied applied;
  if (!solution.usable) return applied;
  const LocalBaProblem& p = solution.problem;
  for (size_t i = 0; i < p.keyframes.size(); ++i) {
    Keyframe& k = map->keyframes[p.keyframes[i]];
    if (p.fixed[i] || k.bad) continue;
    k.cam_from_world = p.cam_from_world[i];
    ++applied.keyframes;
  }
  for (size_t j = 0; j < p.points.size(); ++j) {
    MapPoint& mp = map->points[p.points[j]];
    if (mp.bad) continue;
    mp.position = p.positions[j];
    ++applied.points;
  }
  for (size_t i = 0; i < p.observations.size(); ++i) {
    if (!solution.outlier[i]) continue;
    const LocalBaObservation& o = p.observations[i];
    const int kf = p.keyframes[o.pose];
    Keyframe& k = map->keyframes[kf];
    if (k.bad || k.map_points[o.feature] != p.points[o.point]) continue;  // changed since the snapshot
    map->EraseObservation(kf, o.feature);
    ++applied.erased;
  }
  return applied;
}

}  // namespace dypho
