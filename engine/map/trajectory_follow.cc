#include "engine/map/trajectory_follow.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "common/check.h"

namespace dypho {

KeyframeFollow::KeyframeFollow(const Trajectory& tracked, const Trajectory& keyframes, double time_tolerance) {
  DYPHO_CHECK_INPUT(tracked.world_from_cam.size() == tracked.size() &&
                    keyframes.world_from_cam.size() == keyframes.size())
      << "KeyframeFollow: a trajectory has " << tracked.size() << " / " << keyframes.size()
      << " timestamps but a different number of poses";
  std::map<double, Rigid3d> by_time;  // keyframes in time order (a keyframe mapped twice counts once)
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const double t = keyframes.timestamps[k];
    const auto it = std::lower_bound(tracked.timestamps.begin(), tracked.timestamps.end(), t - time_tolerance);
    if (it == tracked.timestamps.end() || std::abs(*it - t) > time_tolerance) continue;
    const Rigid3d& before = tracked.world_from_cam[it - tracked.timestamps.begin()];
    const Rigid3d& after = keyframes.world_from_cam[k];
    by_time[*it] = after * before.Inverse();
    const double moved = (after.translation - before.translation).norm();
    const double turned = RotationAngle(after.rotation, before.rotation) * 180.0 / M_PI;
    ++stats_.keyframes;
    stats_.mean_translation += moved;
    stats_.mean_rotation_deg += turned;
    stats_.max_translation = std::max(stats_.max_translation, moved);
    stats_.max_rotation_deg = std::max(stats_.max_rotation_deg, turned);
  }
  if (stats_.keyframes > 0) {
    stats_.mean_translation /= stats_.keyframes;
    stats_.mean_rotation_deg /= stats_.keyframes;
  }
  for (const auto& [t, c] : by_time) {
    times_.push_back(t);
    corrections_.push_back(c);
  }
}

Rigid3d KeyframeFollow::CorrectionAt(double timestamp) const {
  if (times_.empty()) return Rigid3d();
  if (timestamp <= times_.front()) return corrections_.front();
  if (timestamp >= times_.back()) return corrections_.back();
  const size_t b = std::upper_bound(times_.begin(), times_.end(), timestamp) - times_.begin();
  const size_t a = b - 1;
  const double s = (timestamp - times_[a]) / (times_[b] - times_[a]);
  return Interpolate(corrections_[a], corrections_[b], s);
}

Rigid3d KeyframeFollow::MoveCamFromWorld(double timestamp, const Rigid3d& cam_from_world) const {
  return (CorrectionAt(timestamp) * cam_from_world.Inverse()).Inverse();
}

Trajectory KeyframeFollow::Apply(const Trajectory& trajectory) const {
  Trajectory out = trajectory;
  if (times_.empty()) return out;
  for (size_t i = 0; i < out.size(); ++i)
    out.world_from_cam[i] = CorrectionAt(out.timestamps[i]) * out.world_from_cam[i];
  return out;
}

KeyframeFollow MapperKeyframeFollow(const Mapper& mapper) {
  std::vector<std::pair<double, int>> by_time;
  for (int k = 0; k < mapper.num_keyframes(); ++k) by_time.push_back({mapper.KeyframeTimestamp(k), k});
  std::sort(by_time.begin(), by_time.end());
  Trajectory given, refined;
  for (const auto& [t, k] : by_time) {
    if (!given.empty() && t <= given.timestamps.back()) continue;  // one keyframe per time
    given.Add(t, mapper.KeyframeGivenPose(k).Inverse());
    refined.Add(t, mapper.KeyframePose(k).Inverse());
  }
  return KeyframeFollow(given, refined, 0.0);
}

}  // namespace dypho
