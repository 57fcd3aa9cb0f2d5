// Step 9 of the ORB tracker (tracker/orb_tracker.h): loop detection and
// closure after a keyframe.
#include <algorithm>
#include <string>

#include "common/check.h"
#include "common/logging.h"
#include "tracker/backend/local_ba.h"
#include "tracker/backend/loop_correction.h"
#include "tracker/orb_tracker_impl.h"

namespace dypho {

using namespace orb_internal;

bool OrbTracker::Impl::CloseLoops(int kf, Rigid3d* pose) {
  if (!vocabulary || bow.Vector(kf) == nullptr) return false;
  const auto t0 = Clock::now();
  const LoopDetectionResult detection = loop_detector.Detect(map, bow, kf);
  const double query_ms = Ms(t0, Clock::now());
  if (map.live_keyframes >= options.loops.min_keyframes) {
    ++backend.loop_queries;
    backend.loop_query_ms += query_ms;
    backend.loop_query_max_ms = std::max(backend.loop_query_max_ms, query_ms);
    backend.loop_candidates += detection.candidates;
    backend.loop_rejected += detection.consistent - detection.verified;
  }
  if (!detection.found) {
    if (detection.candidates > 0)
      DYPHO_LOG(Debug) << "loops: keyframe " << kf << ": no loop (" << detection.reason << ")";
    return false;
  }
  // The map must not change under a threaded local BA: finish and apply it.
  CollectBackend(/*wait=*/true);
  if (map.keyframes[detection.loop.matched].bad || map.keyframes[kf].bad) return false;
  const LoopCorrection c = CloseLoop(detection.loop, options.loops, &map);
  backend.pose_graph_ms += c.graph.solve_ms;
  double global_ba_ms = 0.0;
  if (options.loops.global_ba) {
    // Global BA: the points tie the whole map together again (the pose
    // graph spreads the loop's error evenly, where the drift was not).
    std::vector<Rigid3d> before(keyframes.size()), after(keyframes.size());
    for (size_t k = 0; k < keyframes.size(); ++k) before[k] = keyframes[k].cam_from_world.Inverse();
    LocalBaOptions ba = options.local_ba;
    ba.iterations = options.loops.global_ba_iterations;
    const LocalBaSolution solution = SolveLocalBa(
        camera,
        BuildGlobalBaProblem(map, c.matched, camera, options.extractor.scale_factor, options.rolling_shutter_readout),
        ba, options.optimizer);
    if (solution.usable) {
      const LocalBaApplied applied = ApplyLocalBa(solution, &map);
      backend.erased_observations += applied.erased;
      for (size_t k = 0; k < keyframes.size(); ++k) after[k] = keyframes[k].cam_from_world.Inverse();
      MoveCulledKeyframes(before, &after, map);
      for (size_t k = 0; k < keyframes.size(); ++k)
        if (keyframes[k].bad) keyframes[k].cam_from_world = after[k].Inverse();
    }
    global_ba_ms = solution.solve_ms;
    backend.global_ba_ms += global_ba_ms;
  }
  LoopRecord record;
  record.timestamp = keyframes[kf].timestamp;
  record.keyframe = kf;
  record.matched = c.matched;
  record.score = detection.loop.score;
  record.inliers = detection.loop.verification.num_inliers;
  record.fused = c.fused;
  record.translation = c.translation;
  record.rotation_deg = c.rotation_deg;
  record.pose_graph_ms = c.graph.solve_ms;
  record.global_ba_ms = global_ba_ms;
  backend.loops.push_back(record);
  DYPHO_LOG(Info) << "loop closed: keyframe " << kf << " with keyframe " << c.matched << " (score "
                  << detection.loop.score << ", " << record.inliers << " inliers, " << c.fused << " points fused, "
                  << c.window << " keyframes in the window, " << c.edges << " graph edges of which " << c.loop_edges
                  << " loop edges); correction " << 100.0 * c.translation << " cm, " << c.rotation_deg
                  << " deg; graph " << c.graph.solve_ms << " ms, global BA " << global_ba_ms << " ms";
  *pose = keyframes[kf].cam_from_world;  // the frame is the keyframe
  return true;
}

double OrbTracker::KeyframeTimestamp(int id) const {
  DYPHO_CHECK_INPUT(id >= 0 && id < static_cast<int>(impl_->keyframes.size()))
      << "KeyframeTimestamp: keyframe " << id << " is unknown (" << impl_->keyframes.size() << " keyframes)";
  return impl_->keyframes[id].timestamp;
}

LoopCandidateMatch OrbTracker::VerifyLoopCandidate(int kf, int candidate) const {
  const int n = static_cast<int>(impl_->keyframes.size());
  DYPHO_CHECK_INPUT(kf >= 0 && kf < n && !impl_->keyframes[kf].bad)
      << "VerifyLoopCandidate: keyframe " << kf << " is unknown or culled (" << n << " keyframes)";
  DYPHO_CHECK_INPUT(candidate >= 0 && candidate < n && !impl_->keyframes[candidate].bad && candidate != kf)
      << "VerifyLoopCandidate: candidate " << candidate << " is unknown, culled or the keyframe itself";
  return impl_->loop_detector.Verify(impl_->map, kf, candidate, 0.0);
}

}  // namespace dypho
