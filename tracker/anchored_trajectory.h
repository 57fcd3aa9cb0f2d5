// A trajectory whose frames move with their reference keyframes: each
// tracked frame is stored as cam_from_keyframe (at tracking time) and its
// final pose is cam_from_keyframe * keyframe_from_world with the keyframe's
// pose as the back end (local BA) left it, as ORB-SLAM writes its
// trajectories. Frames without a reference keyframe keep their pose.
#pragma once

#include <utility>
#include <vector>

#include "common/rigid3.h"
#include "tracker/orb_tracker.h"

namespace dypho {

class AnchoredTrajectory {
 public:
  // Call right after tracker.Track(...) returned `result`.
  void Add(const TrackResult& result, const OrbTracker& tracker);
  // cam_from_world of every frame added, with the tracker's current keyframe
  // poses (call tracker.FlushBackend() first in threaded mode).
  std::vector<Rigid3d> CamFromWorld(const OrbTracker& tracker) const;
  size_t size() const { return frames_.size(); }

 private:
  // (reference keyframe or -1, cam_from_keyframe or cam_from_world)
  std::vector<std::pair<int, Rigid3d>> frames_;
};

}  // namespace dypho
