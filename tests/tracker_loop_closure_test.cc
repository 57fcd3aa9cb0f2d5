// Loop closure in the ORB tracker on the synthetic loop (engine/synth, motion
// "loop": the camera circles the room looking outwards and comes back to its
// first view after 12 s). At 320x240 with Kinect-like depth noise the tracker
// drifts by itself: the raw trajectory misses its start by about 20 cm and
// 6 degrees (no injected noise needed); the loop
// must be found within a few frames of the revisit and bring the ATE to at
// most a third of the raw one. A wrong candidate (the far side of the room)
// fails verification, and a path that never returns (most of a lap past the
// room's repeated tiles) closes no loop.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "engine/eval/ate.h"
#include "engine/eval/trajectory.h"
#include "engine/synth/camera_motion.h"
#include "engine/synth/synthetic_scene.h"
#include "tracker/anchored_trajectory.h"
#include "tracker/cv_view.h"
#include "tracker/orb_tracker.h"

namespace dypho {
namespace {

constexpr double kFps = 15.0;
constexpr int kLapFrames = static_cast<int>(synth::kLoopPeriod * kFps);  // frame kLapFrames is frame 0's pose
constexpr int kFrames = kLapFrames + 20;

struct Sequence {
  Camera camera;
  Trajectory ground_truth;
  std::vector<double> timestamps;
  std::vector<cv::Mat> rgb, depth;
};

// 320x240, no walkers, Kinect-like depth noise.
const Sequence& Loop() {
  static const Sequence sequence = [] {
    SynthOptions options;
    options.width = 320;
    options.height = 240;
    options.fps = kFps;
    options.frames = kFrames;
    options.num_walkers = 0;
    options.seed = 5;
    options.motion = SynthMotion::kLoop;
    const SyntheticScene scene(options);
    Sequence s;
    s.camera = scene.camera();
    s.ground_truth = scene.trajectory();
    for (int i = 0; i < scene.num_frames(); ++i) {
      const SynthFrame f = scene.Render(i);
      s.timestamps.push_back(f.timestamp);
      s.rgb.push_back(CvView(f.rgb).clone());
      s.depth.push_back(CvView(f.depth).clone());
    }
    return s;
  }();
  return sequence;
}

OrbTrackerOptions Options(bool loops, int keyframe_max_frames = 30) {
  OrbTrackerOptions o;
  o.keyframe_max_frames = keyframe_max_frames;
  o.local_ba.threaded = false;  // deterministic
  o.loops.enabled = loops;
  return o;
}

struct LoopRun {
  double ate = 0.0;
  int tracked = 0;
  int first_loop_frame = -1;
  OrbBackendStats stats;
  int keyframes = 0;
};

LoopRun Track(const Sequence& s, int frames, const OrbTrackerOptions& options, OrbTracker** keep = nullptr) {
  static std::unique_ptr<OrbTracker> kept;
  auto tracker = std::make_unique<OrbTracker>(s.camera, options);
  AnchoredTrajectory anchored;
  Trajectory estimate;
  LoopRun run;
  for (int i = 0; i < frames; ++i) {
    TrackerFrame frame;
    frame.timestamp = s.timestamps[i];
    frame.image = s.rgb[i];
    frame.depth = s.depth[i];
    const TrackResult r = tracker->Track(frame);
    run.tracked += IsTracked(r.status);
    if (r.loop_closed && run.first_loop_frame < 0) run.first_loop_frame = i;
    anchored.Add(r, *tracker);
    estimate.Add(frame.timestamp, r.cam_from_world.Inverse());
  }
  tracker->FlushBackend();
  const std::vector<Rigid3d> poses = anchored.CamFromWorld(*tracker);
  for (size_t i = 0; i < estimate.size(); ++i) estimate.world_from_cam[i] = poses[i].Inverse();
  const AteResult ate = ComputeAte(s.ground_truth, estimate);
  run.ate = ate.translation.rmse;
  run.stats = tracker->backend_stats();
  run.keyframes = tracker->num_keyframes();
  if (keep != nullptr) {
    kept = std::move(tracker);
    *keep = kept.get();
  }
  return run;
}

TEST(TrackerLoopClosure, SyntheticLoopIsClosedAndTheAteDropsToAThird) {
  const Sequence& s = Loop();
  const LoopRun raw = Track(s, kFrames, Options(false));
  OrbTracker* tracker = nullptr;
  const LoopRun closed = Track(s, kFrames, Options(true), &tracker);
  std::printf("synthetic loop, %d frames (lap at %d): ATE without loops %.2f cm, with %.2f cm; %zu loops, first at "
              "frame %d; %d keyframes; %d queries %.2f ms mean, pose graph %.1f ms\n",
              kFrames, kLapFrames, 100.0 * raw.ate, 100.0 * closed.ate, closed.stats.loops.size(),
              closed.first_loop_frame, closed.keyframes, closed.stats.loop_queries,
              closed.stats.loop_queries ? closed.stats.loop_query_ms / closed.stats.loop_queries : 0.0,
              closed.stats.pose_graph_ms);
  for (const LoopRecord& l : closed.stats.loops)
    std::printf("  loop: keyframe %d with %d, %d inliers, %d fused, %.2f cm %.2f deg\n", l.keyframe, l.matched,
                l.inliers, l.fused, 100.0 * l.translation, l.rotation_deg);
  EXPECT_EQ(raw.tracked, kFrames);
  EXPECT_EQ(closed.tracked, kFrames);
  EXPECT_TRUE(raw.stats.loops.empty());
  ASSERT_FALSE(closed.stats.loops.empty());
  // Several centimetres of drift without loops; a third of it at most with.
  EXPECT_GT(raw.ate, 0.03);
  EXPECT_LE(closed.ate, raw.ate / 3.0);
  // Found within a few frames of the revisit: the first frame of the second
  // half whose view overlaps frame 0's by half (its heading within half the
  // horizontal field of view).
  const double half_fov = std::atan(0.5 * s.camera.width / s.camera.fx);
  int revisit = -1;
  const Eigen::Vector3d forward0 = s.ground_truth.world_from_cam[0].rotation * Eigen::Vector3d::UnitZ();
  for (int i = kLapFrames / 2; i < kFrames && revisit < 0; ++i) {
    const Eigen::Vector3d f = s.ground_truth.world_from_cam[i].rotation * Eigen::Vector3d::UnitZ();
    if (std::acos(std::min(1.0, f.head<2>().normalized().dot(forward0.head<2>().normalized()))) < half_fov)
      revisit = i;
  }
  std::printf("revisit at frame %d, loop closed at frame %d\n", revisit, closed.first_loop_frame);
  ASSERT_GT(revisit, 0);
  EXPECT_GE(closed.first_loop_frame, revisit - 10);
  EXPECT_LE(closed.first_loop_frame, revisit + 15);
  // The loop joins the last keyframes to the first ones.
  EXPECT_LE(closed.stats.loops.front().matched, 2);
  EXPECT_GE(closed.stats.loops.front().inliers, 30);
  EXPECT_GT(closed.stats.loops.front().translation, 0.03);
}

// Loops on the back-end thread (tracker.loops.threaded, fixed lag 2; local
// BA threaded too, fixed lag 1, as in `dypho run`): the same loop as the
// sequential tracker (the same closing keyframe's frame and matched
// keyframe), applied 2 frames later, with the same ATE gain.
TEST(TrackerLoopClosure, ThreadedClosesTheSameLoopAsSequential) {
  const Sequence& s = Loop();
  OrbTracker* tracker = nullptr;
  const LoopRun sequential = Track(s, kFrames, Options(true), &tracker);
  ASSERT_FALSE(sequential.stats.loops.empty());
  const double sequential_matched = tracker->KeyframeTimestamp(sequential.stats.loops.front().matched);
  OrbTrackerOptions o = Options(true);
  o.local_ba.threaded = true;
  o.local_ba.fixed_lag = 1;
  o.loops.threaded = true;
  o.loops.fixed_lag = 2;
  const LoopRun threaded = Track(s, kFrames, o, &tracker);
  ASSERT_FALSE(threaded.stats.loops.empty());
  const LoopRecord& a = sequential.stats.loops.front();
  const LoopRecord& b = threaded.stats.loops.front();
  const double threaded_matched = tracker->KeyframeTimestamp(b.matched);
  std::printf("sequential: loop at t=%.3f (frame %d) with the keyframe at t=%.3f, %d inliers, ATE %.2f cm, %zu "
              "loops\nthreaded:   loop at t=%.3f (frame %d) with the keyframe at t=%.3f, %d inliers, ATE %.2f cm, "
              "%zu loops, applied %ld frames later; %d queries %.2f ms mean on the worker, map snapshots %.2f ms "
              "mean (%.2f max) on the tracking thread\n",
              a.timestamp, sequential.first_loop_frame, sequential_matched, a.inliers, 100 * sequential.ate,
              sequential.stats.loops.size(), b.timestamp, threaded.first_loop_frame, threaded_matched, b.inliers,
              100 * threaded.ate, threaded.stats.loops.size(), b.applied_frames_later, threaded.stats.loop_queries,
              threaded.stats.loop_queries ? threaded.stats.loop_query_ms / threaded.stats.loop_queries : 0.0,
              threaded.stats.loop_queries ? threaded.stats.loop_snapshot_ms / threaded.stats.loop_queries : 0.0,
              threaded.stats.loop_snapshot_max_ms);
  EXPECT_EQ(threaded.tracked, kFrames);
  EXPECT_EQ(b.timestamp, a.timestamp);
  EXPECT_EQ(threaded_matched, sequential_matched);
  EXPECT_EQ(b.applied_frames_later, 2);
  EXPECT_EQ(threaded.first_loop_frame, sequential.first_loop_frame + 2);
  EXPECT_EQ(threaded.stats.loops.size(), sequential.stats.loops.size());
  EXPECT_GT(threaded.stats.loop_snapshot_ms, 0.0);
  const LoopRun raw = Track(s, kFrames, Options(false));
  EXPECT_LE(threaded.ate, raw.ate / 3.0);
}

// On the map of the run without loops: the true loop pair (the last keyframe
// and the first ones) passes verification, the keyframe from the far side of
// the room (half a lap away, where the walls' and floor's textures repeat)
// does not.
TEST(TrackerLoopClosure, VerificationAcceptsTheTrueLoopAndRejectsAWrongCandidate) {
  const Sequence& s = Loop();
  OrbTracker* tracker = nullptr;
  Track(s, kFrames, Options(false), &tracker);
  const std::vector<std::pair<double, Rigid3d>> poses = tracker->KeyframePoses();
  const int last = tracker->num_keyframes() - 1;
  // The keyframe nearest to half a lap (by timestamp).
  const double half = s.timestamps[0] + 0.5 * synth::kLoopPeriod;
  int opposite = -1;
  double best = 1e9;
  for (int k = 0; k < last; ++k) {
    const double dt = std::abs(tracker->KeyframeTimestamp(k) - half);
    if (dt < best) {
      best = dt;
      opposite = k;
    }
  }
  const LoopCandidateMatch wrong = tracker->VerifyLoopCandidate(last, opposite);
  const LoopCandidateMatch right = tracker->VerifyLoopCandidate(last, 1);
  std::printf("keyframe %d: with keyframe 1 %s (%d inliers), with keyframe %d %s (%d inliers: %s)\n", last,
              right.verification.accepted ? "accepted" : "rejected", right.verification.num_inliers, opposite,
              wrong.verification.accepted ? "accepted" : "rejected", wrong.verification.num_inliers,
              wrong.verification.reason.c_str());
  EXPECT_TRUE(right.verification.accepted) << right.verification.reason;
  EXPECT_FALSE(wrong.verification.accepted);
  EXPECT_TRUE(wrong.pairs.empty());
}

// Most of a lap (no revisit) past the room's tiled floor and repeated wall
// textures, with a keyframe every 8 frames (many queries): the BoW database
// proposes candidates and some are consistent, but verification rejects
// them all: no loop.
TEST(TrackerLoopClosure, NoRevisitClosesNoLoop) {
  const Sequence& s = Loop();
  const int frames = kLapFrames * 3 / 4;
  const LoopRun run = Track(s, frames, Options(true, 8));
  std::printf("%d frames (3/4 of a lap): %d loop queries, %d candidates, %d rejected by verification, %zu loops\n",
              frames, run.stats.loop_queries, run.stats.loop_candidates, run.stats.loop_rejected,
              run.stats.loops.size());
  EXPECT_EQ(run.tracked, frames);
  EXPECT_GT(run.stats.loop_queries, 5);
  EXPECT_GT(run.stats.loop_rejected, 0);  // verification is what stops them (measured: 51)
  EXPECT_TRUE(run.stats.loops.empty());
}

}  // namespace
}  // namespace dypho
