#include "engine/pipeline/loop_response.h"

#include <optional>

#include "common/check.h"
#include "common/logging.h"
#include "engine/api.h"
#include "engine/map/keyframe_selector.h"
#include "tracker/orb_tracker.h"

namespace dypho {

int ApplyKeyframeCorrections(const std::vector<PoseCorrection>& corrections,
                             const std::map<long, int>& engine_keyframe_of_frame,
                             const std::function<void(int id, const Rigid3d& cam_from_world)>& update, int* skipped) {
  int moved = 0, missing = 0;
  for (const PoseCorrection& c : corrections) {
    const auto it = engine_keyframe_of_frame.find(c.frame);
    if (it == engine_keyframe_of_frame.end()) {
      ++missing;  // the engine never took this frame as a keyframe
      continue;
    }
    update(it->second, c.cam_from_world);
    ++moved;
  }
  if (skipped) *skipped = missing;
  return moved;
}

void LoopResponse::NoteFrame(long frame, double timestamp, const TrackResult& result, const OrbTracker& tracker) {
  Frame f;
  f.frame = frame;
  f.timestamp = timestamp;
  f.tracked = IsTracked(result.status);
  f.keyframe = f.tracked ? result.reference_keyframe : -1;
  f.cam_from_reference =
      f.keyframe >= 0 ? result.cam_from_world * tracker.KeyframePose(f.keyframe).Inverse() : result.cam_from_world;
  frames_.push_back(f);
  frame_of_timestamp_[timestamp] = frame;
}

void LoopResponse::NoteEngineKeyframe(int id, double timestamp) {
  const auto it = frame_of_timestamp_.find(timestamp);
  DYPHO_CHECK(it != frame_of_timestamp_.end()) << "loop response: engine keyframe " << id << " (t=" << timestamp
                                               << ") is not a frame the tracker saw";
  engine_keyframe_of_frame_[it->second] = id;
}

std::vector<PoseCorrection> LoopResponse::Corrections(const OrbTracker& tracker) const {
  std::vector<PoseCorrection> out;
  out.reserve(frames_.size());
  for (const Frame& f : frames_) {
    if (f.keyframe < 0) continue;
    out.push_back({f.frame, f.cam_from_reference * tracker.KeyframePose(f.keyframe)});
  }
  return out;
}

LoopResponseRecord LoopResponse::Respond(const OrbTracker& tracker, Engine* engine, Trajectory* trajectory,
                                         int refine_steps) {
  LoopResponseRecord r;
  DYPHO_CHECK(!tracker.backend_stats().loops.empty()) << "loop response: the tracker closed no loop";
  const LoopRecord& loop = tracker.backend_stats().loops.back();
  if (!frames_.empty()) r.frame = frames_.back().frame;
  const auto matched = frame_of_timestamp_.find(tracker.KeyframeTimestamp(loop.matched));
  if (matched != frame_of_timestamp_.end()) r.matched_frame = matched->second;
  r.inliers = loop.inliers;
  r.correction_cm = 100.0 * loop.translation;
  r.correction_deg = loop.rotation_deg;

  const std::vector<PoseCorrection> corrections = Corrections(tracker);
  // The trajectory: one line per noted frame; lost frames repeat the
  // corrected pose of the last tracked one before them.
  DYPHO_CHECK(trajectory->size() == frames_.size())
      << "loop response: " << trajectory->size() << " trajectory lines for " << frames_.size() << " frames";
  size_t c = 0;
  std::optional<Rigid3d> last;
  for (size_t i = 0; i < frames_.size(); ++i) {
    if (frames_[i].keyframe >= 0) {
      // A recent frame may be the engine's keyframe candidate, emitted later
      // (a threaded or lagged loop lands frames after its keyframe): its
      // pose too.
      if (frames_.size() - i <= kKeyframeCandidateFrames && !engine_keyframe_of_frame_.count(frames_[i].frame) &&
          engine->UpdateCandidatePose(frames_[i].timestamp, corrections[c].cam_from_world))
        ++r.candidates_moved;
      last = corrections[c++].cam_from_world.Inverse();
      trajectory->world_from_cam[i] = *last;
      ++r.frames_corrected;
    } else if (!frames_[i].tracked && last) {
      trajectory->world_from_cam[i] = *last;
    }
  }
  r.keyframes_moved = ApplyKeyframeCorrections(
      corrections, engine_keyframe_of_frame_,
      [engine](int id, const Rigid3d& pose) { engine->UpdateKeyframePose(id, pose); }, &r.keyframes_skipped);
  // On the mapping thread: the frame loop goes on (30 steps on the tracking
  // thread stalled it for 3-6 s on head250 with walkers).
  r.refine_steps = refine_steps > 0 ? engine->RequestRefine(refine_steps) : 0;
  DYPHO_LOG(Info) << "loop at frame " << r.frame << " (matched frame " << r.matched_frame << "): "
                  << r.keyframes_moved << " engine keyframes and " << r.frames_corrected
                  << " trajectory poses corrected, " << r.refine_steps << " refinement steps";
  return r;
}

}  // namespace dypho
