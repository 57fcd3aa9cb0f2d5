// The KITTI odometry metric (Geiger et al., CVPR 2012): relative translation
// and rotation errors over all sub-sequences of given path lengths.
#pragma once

#include <vector>

#include "engine/eval/trajectory.h"

namespace dypho {

struct KittiError {
  double translation_percent = 0;  // mean |t_err| / length x 100
  double rotation_deg_per_m = 0;   // mean angle(R_err) / length
  int segments = 0;                // sub-sequences evaluated
};

// ground_truth and estimate hold the same frames in the same order (pose i of
// each belongs to frame i; sizes must match). For every first frame and every
// length L, the sub-sequence ends at the first frame whose ground-truth path
// distance from the first is >= L; the error is the relative pose
// (gt_i^-1 gt_j)^-1 (est_i^-1 est_j). Lengths longer than the path give no segments.
KittiError ComputeKittiError(const Trajectory& ground_truth, const Trajectory& estimate,
                             const std::vector<double>& lengths);

}  // namespace dypho
