#include "tracker/anchored_trajectory.h"

namespace dypho {

void AnchoredTrajectory::Add(const TrackResult& result, const OrbTracker& tracker) {
  const int kf = result.reference_keyframe;
  frames_.emplace_back(kf, kf >= 0 ? result.cam_from_world * tracker.KeyframePose(kf).Inverse() : result.cam_from_world);
}

std::vector<Rigid3d> AnchoredTrajectory::CamFromWorld(const OrbTracker& tracker) const {
  std::vector<Rigid3d> out;
  out.reserve(frames_.size());
  for (const auto& [kf, pose] : frames_) out.push_back(kf >= 0 ? pose * tracker.KeyframePose(kf) : pose);
  return out;
}

}  // namespace dypho
