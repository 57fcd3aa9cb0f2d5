#include "tracker/backend/pose_graph.h"

#include <chrono>
#include <cmath>
#include <sstream>

#include <ceres/ceres.h>

#include "common/check.h"

namespace dypho {
namespace {

struct EdgeCost {
  EdgeCost(const Rigid3d& measured, double weight)
      : inv_rotation(measured.rotation.conjugate()), translation(measured.translation), scale(std::sqrt(weight)) {}

  template <typename T>
  bool operator()(const T* qa, const T* ta, const T* qb, const T* tb, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rot_a(qa), rot_b(qb);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> pa(ta), pb(tb);
    // a_from_b estimated.
    const Eigen::Quaternion<T> qa_inv = rot_a.conjugate();
    const Eigen::Quaternion<T> q_ab = qa_inv * rot_b;
    const Eigen::Matrix<T, 3, 1> t_ab = qa_inv * (pb - pa);
    // E = measured^-1 * estimated.
    const Eigen::Quaternion<T> m_inv = inv_rotation.cast<T>();
    Eigen::Quaternion<T> q_e = m_inv * q_ab;
    const Eigen::Matrix<T, 3, 1> t_e = m_inv * (t_ab - translation.cast<T>());
    if (q_e.w() < T(0)) q_e.coeffs() = -q_e.coeffs();
    for (int i = 0; i < 3; ++i) {
      r[i] = T(scale) * t_e[i];
      r[3 + i] = T(2.0 * scale) * q_e.vec()[i];
    }
    return true;
  }

  Eigen::Quaterniond inv_rotation;
  Eigen::Vector3d translation;
  double scale;
};

}  // namespace

bool PoseGraphOptions::IsValid(std::string* error) const {
  if (iterations >= 1) return true;
  if (error != nullptr) *error = "PoseGraphOptions.iterations must be >= 1 (got " + std::to_string(iterations) + ")";
  return false;
}

PoseGraphSummary OptimizePoseGraph(std::vector<Rigid3d>* world_from_cam, const std::vector<char>& fixed,
                                   const std::vector<PoseGraphEdge>& edges, const PoseGraphOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  const int n = static_cast<int>(world_from_cam->size());
  DYPHO_CHECK_INPUT(static_cast<int>(fixed.size()) == n)
      << "OptimizePoseGraph: " << fixed.size() << " fixed flags for " << n << " poses";
  bool any_fixed = false;
  for (char f : fixed) any_fixed = any_fixed || f;
  DYPHO_CHECK_INPUT(any_fixed) << "OptimizePoseGraph: no fixed pose (the gauge is free)";
  // One buffer (quaternion 4, translation 3 per pose): the block order
  // Ceres derives from addresses is then the index order on every run.
  std::vector<double> buffer(7 * static_cast<size_t>(n));
  auto q = [&](int i) { return &buffer[7 * static_cast<size_t>(i)]; };
  auto t = [&](int i) { return &buffer[7 * static_cast<size_t>(i) + 4]; };
  for (int i = 0; i < n; ++i) {
    Eigen::Map<Eigen::Vector4d>(q(i)) = (*world_from_cam)[i].rotation.normalized().coeffs();
    Eigen::Map<Eigen::Vector3d>(t(i)) = (*world_from_cam)[i].translation;
  }
  ceres::Problem problem;
  std::vector<char> used(n, 0);
  for (size_t e = 0; e < edges.size(); ++e) {
    const PoseGraphEdge& edge = edges[e];
    DYPHO_CHECK_INPUT(edge.a >= 0 && edge.a < n && edge.b >= 0 && edge.b < n && edge.a != edge.b)
        << "OptimizePoseGraph: edge " << e << " joins " << edge.a << " and " << edge.b << " (" << n << " poses)";
    DYPHO_CHECK_INPUT(edge.weight > 0.0 && std::isfinite(edge.weight))
        << "OptimizePoseGraph: edge " << e << " has weight " << edge.weight;
    DYPHO_CHECK_INPUT(edge.a_from_b.rotation.coeffs().allFinite() && edge.a_from_b.translation.allFinite())
        << "OptimizePoseGraph: edge " << e << " has a non-finite measurement";
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<EdgeCost, 6, 4, 3, 4, 3>(
                                 new EdgeCost(edge.a_from_b, edge.weight)),
                             nullptr, q(edge.a), t(edge.a), q(edge.b), t(edge.b));
    used[edge.a] = used[edge.b] = 1;
  }
  PoseGraphSummary summary;
  if (edges.empty()) return summary;
  for (int i = 0; i < n; ++i) {
    if (!used[i]) continue;
    problem.SetManifold(q(i), new ceres::EigenQuaternionManifold());
    if (fixed[i]) {
      problem.SetParameterBlockConstant(q(i));
      problem.SetParameterBlockConstant(t(i));
    }
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = options.iterations;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  solver.function_tolerance = 1e-12;
  solver.gradient_tolerance = 1e-14;
  solver.parameter_tolerance = 1e-12;
  ceres::Solver::Summary s;
  ceres::Solve(solver, &problem, &s);
  for (int i = 0; i < n; ++i)
    if (!fixed[i]) {
      const Eigen::Map<const Eigen::Vector4d> qi(q(i));
      const Eigen::Map<const Eigen::Vector3d> ti(t(i));
      if (qi.allFinite() && ti.allFinite()) (*world_from_cam)[i] = Rigid3d(Eigen::Quaterniond(q(i)), ti);
    }
  summary.initial_cost = s.initial_cost;
  summary.final_cost = s.final_cost;
  summary.iterations = s.num_successful_steps + s.num_unsuccessful_steps;
  summary.solve_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace dypho
