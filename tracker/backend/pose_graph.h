// SE(3) pose-graph optimisation (the essential graph of ORB-SLAM for RGB-D:
// spanning-tree, strong-covisibility and loop edges, without scale). Nodes
// are keyframe poses world_from_cam; an edge (a, b) measures a_from_b =
// world_from_a^-1 * world_from_b. Residual of an edge, with E =
// measured_a_from_b^-1 * (world_from_a^-1 * world_from_b) = (q_E, t_E):
//   r = sqrt(weight) * (t_E, 2 * vec(q_E))   (6 values, q_E with w >= 0)
// Solved with Ceres (automatic derivatives, Eigen quaternion manifold,
// sparse normal Cholesky, LM); fixed nodes hold the gauge.
#pragma once

#include <string>
#include <vector>

#include "common/rigid3.h"

namespace dypho {

struct PoseGraphEdge {
  int a = -1;
  int b = -1;
  Rigid3d a_from_b;     // measured
  double weight = 1.0;  // > 0
};

struct PoseGraphOptions {
  int iterations = 50;  // LM iterations at most, >= 1

  bool IsValid(std::string* error) const;
};

struct PoseGraphSummary {
  double initial_cost = 0.0;
  double final_cost = 0.0;
  int iterations = 0;
  double solve_ms = 0.0;
};

// Optimises `world_from_cam` in place; nodes with fixed[i] != 0 stay. Throws
// InvalidInput naming the edge for an index out of range, a non-positive
// weight or a non-finite measurement, and when no node is fixed.
PoseGraphSummary OptimizePoseGraph(std::vector<Rigid3d>* world_from_cam, const std::vector<char>& fixed,
                                   const std::vector<PoseGraphEdge>& edges, const PoseGraphOptions& options);

}  // namespace dypho
