// Trajectory error metrics with the definitions of the TUM RGB-D benchmark
// tools (Sturm et al., "A Benchmark for the Evaluation of RGB-D SLAM
// Systems", IROS 2012; evaluate_ate.py and evaluate_rpe.py from
// https://cvg.cit.tum.de/data/datasets/rgbd-dataset/tools):
//
// ATE (evaluate_ate.py): estimated and ground-truth poses are matched by
//   timestamp (associate.py: |t_gt - (t_est + offset)| < 0.02 s, greedy by
//   smallest difference, each pose used once). The estimated positions are
//   aligned to the ground-truth positions by the closed-form least-squares
//   rigid transform (Horn 1987 / Umeyama 1991; SVD of the cross-covariance
//   with the reflection fixed), optionally with a scale (Sim(3), Umeyama).
//   The error of a match is the Euclidean distance between the aligned
//   estimated position and the ground-truth position; statistics are taken
//   over all matches (RMSE = sqrt(sum e^2 / n), std is the population std).
//
// RPE (evaluate_rpe.py --fixed_delta --delta 1 --delta_unit s): for every
//   estimated pose i, j is the estimated pose whose timestamp is closest to
//   t_i + delta; pairs whose j is the last estimated pose are skipped (as the
//   TUM tool does). Each of t_i, t_j is matched to the closest ground-truth
//   timestamp, and the pair is skipped when either is further than twice the
//   median ground-truth sampling interval. With the TUM tool's
//   ominus(a, b) = a^-1 b, the error is
//     E = (scale(E_j^-1 E_i))^-1 (G_j^-1 G_i)
//   (E, G: world_from_cam 4x4 of estimate and ground truth); the translation
//   error is |t(E)| [m], the rotation error the angle of R(E) [deg].
//   Differences from the TUM tool: all pairs are used (the tool samples
//   10000 at random when there are more), and every rotation statistic is
//   in degrees (the tool prints the median in radians).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "common/rigid3.h"
#include "engine/eval/trajectory.h"

namespace dypho {

// Summary of a list of non-negative errors (as printed by the TUM tools).
struct ErrorStats {
  size_t count = 0;     // number of errors
  double rmse = 0.0;    // sqrt(mean(e^2))
  double mean = 0.0;    // mean(e)
  double median = 0.0;  // middle value (mean of the two middle ones for even counts)
  double std = 0.0;     // population standard deviation
  double min = 0.0;     // smallest error
  double max = 0.0;     // largest error
};
// Statistics of `errors`; all zero when empty.
ErrorStats ComputeErrorStats(const std::vector<double>& errors);

struct AteOptions {
  double max_time_difference = 0.02;  // [s] largest |t_gt - (t_est + offset)| for a match (strict)
  double time_offset = 0.0;           // [s] added to estimated timestamps before matching
  bool estimate_scale = false;        // align with Sim(3) (for monocular or unscaled estimates)

  bool IsValid(std::string* error) const;
};

struct AteResult {
  ErrorStats translation;  // [m] position error after alignment
  // The alignment: aligned = scale * (rotation * p_est) + translation.
  Rigid3d gt_from_est;  // rotation and translation of the alignment
  double scale = 1.0;   // 1 unless AteOptions::estimate_scale
  // One entry per matched pose, in timestamp order.
  std::vector<size_t> gt_indices;                  // index into the ground truth
  std::vector<size_t> est_indices;                 // index into the estimate
  std::vector<double> timestamps;                  // [s] estimated timestamps of the matches
  std::vector<double> errors;                      // [m] per-match position error
  std::vector<Eigen::Vector3d> gt_positions;       // [m] matched ground-truth positions
  std::vector<Eigen::Vector3d> aligned_positions;  // [m] matched estimated positions, aligned
  size_t unmatched_estimates = 0;                  // estimated poses without a ground-truth match

  // The alignment applied to a point or a pose (for plotting the full estimate).
  Eigen::Vector3d Align(const Eigen::Vector3d& p_est) const;
  Rigid3d Align(const Rigid3d& world_from_cam_est) const;
};

// Absolute trajectory error. Throws InvalidInput (naming the counts) when
// fewer than 2 poses match, like evaluate_ate.py.
AteResult ComputeAte(const Trajectory& ground_truth, const Trajectory& estimate,
                     const AteOptions& options = AteOptions());

// The whole estimate with the ATE alignment applied (translations scaled).
Trajectory AlignTrajectory(const Trajectory& estimate, const AteResult& ate);

struct RpeOptions {
  double delta = 1.0;        // [s] time between the two poses of a pair
  double time_offset = 0.0;  // [s] added to estimated timestamps before matching
  double scale = 1.0;        // factor applied to estimated relative translations

  bool IsValid(std::string* error) const;
};

struct RpePair {
  double est_time_0 = 0.0;         // [s] first estimated timestamp
  double est_time_1 = 0.0;         // [s] second estimated timestamp
  double gt_time_0 = 0.0;          // [s] matched ground-truth timestamps
  double gt_time_1 = 0.0;          // [s]
  double translation_error = 0.0;  // [m]
  double rotation_error = 0.0;     // [deg]
};

struct RpeResult {
  ErrorStats translation;      // [m] per delta
  ErrorStats rotation;         // [deg] per delta
  std::vector<RpePair> pairs;  // the compared pairs, in estimated time order
};

// Relative pose error over a fixed time delta. Throws InvalidInput when the
// trajectories do not overlap or fewer than 2 pairs can be compared, like
// evaluate_rpe.py.
RpeResult ComputeRpe(const Trajectory& ground_truth, const Trajectory& estimate,
                     const RpeOptions& options = RpeOptions());

}  // namespace dypho
