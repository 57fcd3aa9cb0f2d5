// The frames' trajectory follows the map's refined keyframes.
//
// With keyframe pose refinement (mapper.refine_poses) the mapper moves its
// keyframes photometrically, against the map, after the tracker gave their
// poses; the other frames keep the tracker's poses. Left so, a frame
// between two keyframes sits in a map that moved under it: on
// tum_fr1_rpy_head250 the refinement moved the keyframes by 2-14 mm and
// 0.1-0.9 degrees, and the map rendered at the tracker's poses of the other
// frames scored 0.3 dB lower than the map made without refinement
// (BENCHMARKS.md).
//
// Each keyframe k found in the trajectory (same timestamp) gives a
// correction on the world side, C_k = refined_k * tracked_k^-1 (poses
// world_from_cam), so that C_k * tracked_k = refined_k. A frame at time t
// between keyframes a and b gets C(t) = Interpolate(C_a, C_b, s), s = (t -
// t_a) / (t_b - t_a) (slerp of the rotation, lerp of the translation), the
// first keyframe's before it and the last keyframe's after it:
// world_from_cam' = C(t) * world_from_cam. A keyframe's own line becomes its
// refined pose; where no keyframe moved, nothing changes.
#pragma once

#include <vector>

#include "common/rigid3.h"
#include "engine/eval/trajectory.h"
#include "engine/map/mapper.h"

namespace dypho {

struct FollowStats {
  int keyframes = 0;              // keyframes found in the trajectory
  double mean_translation = 0.0;  // [m] of the keyframes' corrections (at the keyframe)
  double max_translation = 0.0;   // [m]
  double mean_rotation_deg = 0.0;
  double max_rotation_deg = 0.0;
};

class KeyframeFollow {
 public:
  // `tracked`: the frames' trajectory (world_from_cam); `keyframes`: the
  // keyframes' poses now (world_from_cam, e.g. Engine::MappedKeyframes()).
  // A keyframe is matched to the trajectory line within `time_tolerance`
  // seconds of its timestamp; keyframes without one are left out.
  KeyframeFollow(const Trajectory& tracked, const Trajectory& keyframes, double time_tolerance = 1e-4);

  // C(t), the identity when no keyframe was matched.
  Rigid3d CorrectionAt(double timestamp) const;
  // A camera pose (cam_from_world) at `timestamp` moved by C there.
  Rigid3d MoveCamFromWorld(double timestamp, const Rigid3d& cam_from_world) const;
  // Every line of `trajectory` moved by C at its time.
  Trajectory Apply(const Trajectory& trajectory) const;
  const FollowStats& stats() const { return stats_; }

 private:
  std::vector<double> times_;
  std::vector<Rigid3d> corrections_;
  FollowStats stats_;
};

// The mapper's keyframes as given (AddKeyframe, SetKeyframePose) and as
// refined now (refine_poses): frames between them follow them.
KeyframeFollow MapperKeyframeFollow(const Mapper& mapper);

}  // namespace dypho
