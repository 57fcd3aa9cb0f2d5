// Step 9 of the ORB tracker (tracker/orb_tracker.h): loop detection and
// closure after a keyframe. Sequential (tracker.loops.threaded = false): on
// the live map, right after the keyframe. Threaded: on a snapshot, on the
// loop worker (tracker/backend/loop_worker.h); the outcome is applied to the
// live map at a later frame (ApplyLoopOutcome).
#include <algorithm>
#include <string>
#include <utility>

#include "common/check.h"
#include "common/logging.h"
#include "tracker/backend/local_ba.h"
#include "tracker/backend/loop_correction.h"
#include "tracker/orb_tracker_impl.h"

namespace dypho {

using namespace orb_internal;

namespace {

// Steps 1-3 of the detection (loop_detection.h) for keyframe `kf`.
LoopOutcome DetectLoop(LoopDetector* detector, const SparseMap& map, const BowDatabase& bow, int kf,
                       const LoopClosingOptions& options) {
  LoopOutcome o;
  o.keyframe = kf;
  const auto t0 = Clock::now();
  o.detection = detector->Detect(map, bow, kf);
  o.query_ms = Ms(t0, Clock::now());
  o.queried = map.live_keyframes >= options.min_keyframes;
  return o;
}

}  // namespace

// The closure of the loop detected in `o` on `map`: the pose graph
// (loop_correction.h), then the global BA (loops.global_ba). With
// `record_motion`, how it moved every keyframe and point (the threaded
// outcome).
void OrbTracker::Impl::CloseDetectedLoop(LoopOutcome* o, SparseMap* map, bool record_motion) const {
  std::vector<Keyframe>& kfs = map->keyframes;
  const size_t n = kfs.size();
  std::vector<Rigid3d> start(n);
  for (size_t k = 0; k < n; ++k) start[k] = kfs[k].cam_from_world.Inverse();
  if (record_motion) {
    o->points_before.resize(map->points.size());
    for (size_t i = 0; i < map->points.size(); ++i) o->points_before[i] = map->points[i].position;
  }
  o->correction = CloseLoop(o->detection.loop, options.loops, map);
  o->closed = true;
  if (options.loops.global_ba) {
    // Global BA: the points tie the whole map together again (the pose
    // graph spreads the loop's error evenly, where the drift was not).
    std::vector<Rigid3d> before(n), after(n);
    for (size_t k = 0; k < n; ++k) before[k] = kfs[k].cam_from_world.Inverse();
    LocalBaOptions ba = options.local_ba;
    ba.iterations = options.loops.global_ba_iterations;
    const LocalBaSolution solution =
        SolveLocalBa(camera,
                     BuildGlobalBaProblem(*map, o->correction.matched, camera, options.extractor.scale_factor,
                                          options.rolling_shutter_readout),
                     ba, options.optimizer);
    if (solution.usable) {
      o->erased = ApplyLocalBa(solution, map).erased;
      for (size_t k = 0; k < n; ++k) after[k] = kfs[k].cam_from_world.Inverse();
      MoveCulledKeyframes(before, &after, *map);
      for (size_t k = 0; k < n; ++k)
        if (kfs[k].bad) kfs[k].cam_from_world = after[k].Inverse();
    }
    o->global_ba_ms = solution.solve_ms;
  }
  if (record_motion) {
    o->world_corrections.resize(n);
    for (size_t k = 0; k < n; ++k) o->world_corrections[k] = kfs[k].cam_from_world.Inverse() * start[k].Inverse();
    o->points_after.resize(map->points.size());
    for (size_t i = 0; i < map->points.size(); ++i) o->points_after[i] = map->points[i].position;
  }
}

LoopOutcome OrbTracker::Impl::ProcessLoopJob(LoopDetector* detector, LoopJob job) const {
  if (job.reset) {
    detector->Reset();
    LoopOutcome o;
    o.frame = job.frame;
    return o;
  }
  LoopOutcome o = DetectLoop(detector, job.map, job.bow, job.keyframe, options.loops);
  o.frame = job.frame;
  if (o.detection.found) CloseDetectedLoop(&o, &job.map, /*record_motion=*/true);
  return o;
}

void OrbTracker::Impl::NoteLoopQuery(const LoopOutcome& o) {
  if (o.queried) {
    ++backend.loop_queries;
    backend.loop_query_ms += o.query_ms;
    backend.loop_query_max_ms = std::max(backend.loop_query_max_ms, o.query_ms);
    backend.loop_candidates += o.detection.candidates;
    backend.loop_rejected += o.detection.consistent - o.detection.verified;
  }
  if (!o.detection.found && o.detection.candidates > 0) {
    DYPHO_LOG(Debug) << "loops: keyframe " << o.keyframe << ": no loop (" << o.detection.reason << ")";
  }
}

void OrbTracker::Impl::RecordLoop(const LoopOutcome& o) {
  const LoopCorrection& c = o.correction;
  backend.pose_graph_ms += c.graph.solve_ms;
  backend.global_ba_ms += o.global_ba_ms;
  backend.erased_observations += o.erased;
  LoopRecord record;
  record.timestamp = keyframes[o.keyframe].timestamp;
  record.keyframe = o.keyframe;
  record.matched = c.matched;
  record.score = o.detection.loop.score;
  record.inliers = o.detection.loop.verification.num_inliers;
  record.fused = c.fused;
  record.translation = c.translation;
  record.rotation_deg = c.rotation_deg;
  record.pose_graph_ms = c.graph.solve_ms;
  record.global_ba_ms = o.global_ba_ms;
  record.applied_frames_later = frame_counter - o.frame;
  backend.loops.push_back(record);
  DYPHO_LOG(Info) << "loop closed: keyframe " << o.keyframe << " with keyframe " << c.matched << " (score "
                  << record.score << ", " << record.inliers << " inliers, " << c.fused << " points fused, "
                  << c.window << " keyframes in the window, " << c.edges << " graph edges of which " << c.loop_edges
                  << " loop edges); correction " << 100.0 * c.translation << " cm, " << c.rotation_deg
                  << " deg; graph " << c.graph.solve_ms << " ms, global BA " << o.global_ba_ms << " ms"
                  << (loop_worker ? "; applied " + std::to_string(record.applied_frames_later) + " frames later" : "");
}

bool OrbTracker::Impl::CloseLoops(int kf, Rigid3d* pose) {
  if (!vocabulary || bow.Vector(kf) == nullptr) return false;
  if (loop_worker) {
    SubmitLoopQuery(kf);
    return false;
  }
  LoopOutcome o = DetectLoop(&loop_detector, map, bow, kf, options.loops);
  o.frame = frame_counter;
  NoteLoopQuery(o);
  if (!o.detection.found) return false;
  // The map must not change under a threaded local BA: finish and apply it.
  CollectBackend(/*wait=*/true);
  if (map.keyframes[o.detection.loop.matched].bad || map.keyframes[kf].bad) return false;
  CloseDetectedLoop(&o, &map, /*record_motion=*/false);
  RecordLoop(o);
  *pose = keyframes[kf].cam_from_world;  // the frame is the keyframe
  return true;
}

void OrbTracker::Impl::SubmitLoopQuery(int kf) {
  LoopJob job;
  job.frame = frame_counter;
  job.keyframe = kf;
  if (map.live_keyframes < options.loops.min_keyframes) {
    job.reset = true;  // as Detect does below min_keyframes
  } else {
    const auto t0 = Clock::now();
    job.map = map;
    job.bow = bow;
    const double ms = Ms(t0, Clock::now());
    backend.loop_snapshot_ms += ms;
    backend.loop_snapshot_max_ms = std::max(backend.loop_snapshot_max_ms, ms);
  }
  loop_worker->Submit(std::move(job));
}

bool OrbTracker::Impl::CollectLoops(bool wait_all) {
  if (!loop_worker) return false;
  const int lag = options.loops.fixed_lag;
  bool closed = false;
  while (true) {
    const long oldest = loop_worker->OldestFrame();
    if (oldest < 0) break;
    std::optional<LoopOutcome> o;
    if (wait_all || (lag > 0 && frame_counter - oldest >= lag)) {
      o = loop_worker->WaitAndTake();
    } else if (lag == 0) {
      o = loop_worker->Take();
    }
    if (!o) break;
    closed = ApplyLoopOutcome(*o) || closed;
  }
  return closed;
}

void OrbTracker::Impl::DropLoopJobs() {
  if (!loop_worker) return;
  while (loop_worker->WaitAndTake()) {
  }
  LoopJob reset;  // the worker's detector forgets the old map's groups
  reset.reset = true;
  reset.frame = frame_counter;
  loop_worker->Submit(std::move(reset));
  loop_applied_frame = -1;
}

// A threaded outcome on the live map, which has changed since the snapshot
// (new keyframes and points, local BAs): every keyframe of the snapshot
// moves as the closure moved it there (on top of the local BAs since),
// keyframes made after the snapshot move as the closing keyframe moved; a
// point the local BA has not touched since takes its position from the
// closure, any other moves with its reference keyframe; then the pairs are
// fused. Global-BA outlier removal on the snapshot is not replayed.
bool OrbTracker::Impl::ApplyLoopOutcome(const LoopOutcome& o) {
  NoteLoopQuery(o);
  if (!o.closed) return false;
  if (o.frame < loop_applied_frame) {
    // Found on a snapshot from before the last closure was applied.
    DYPHO_LOG(Debug) << "loops: keyframe " << o.keyframe << ": stale loop dropped (snapshot at frame " << o.frame
                     << ", a closure was applied at frame " << loop_applied_frame << ")";
    return false;
  }
  CollectBackend(/*wait=*/true);  // a local BA in flight was solved on the uncorrected map
  const int n = static_cast<int>(o.world_corrections.size());
  DYPHO_CHECK(o.keyframe >= 0 && o.keyframe < n && n <= static_cast<int>(keyframes.size()))
      << "loop outcome: keyframe " << o.keyframe << " of " << n << " snapshot keyframes, " << keyframes.size()
      << " live";
  auto delta = [&](int k) -> const Rigid3d& { return o.world_corrections[k < n ? k : o.keyframe]; };
  for (int k = 0; k < static_cast<int>(keyframes.size()); ++k)
    keyframes[k].cam_from_world = (delta(k) * keyframes[k].cam_from_world.Inverse()).Inverse();
  const long snapshot_points = static_cast<long>(o.points_before.size());
  for (long id = 0; id < static_cast<long>(points.size()); ++id) {
    MapPoint& mp = points[id];
    if (mp.bad || mp.keyframes.empty()) continue;
    if (id < snapshot_points && mp.position == o.points_before[id]) {
      mp.position = o.points_after[id];
    } else {
      mp.position = delta(mp.keyframes.front()) * mp.position;
    }
  }
  FuseLoopPairs(o.detection.loop.pairs, &map);
  // The last frame (the next one's motion model) moves with its reference.
  last_pose = (delta(reference_keyframe >= 0 ? reference_keyframe : o.keyframe) * last_pose.Inverse()).Inverse();
  ForgetBadLastPoints();
  loop_applied_frame = frame_counter;
  RecordLoop(o);
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
