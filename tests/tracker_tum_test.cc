// The ORB tracker on the real TUM RGB-D fr1/rpy sequence (first 250 frames:
// fast rotations, motion blur, a rolling-shutter camera, no dynamic
// objects): every frame is tracked and the ATE stays below 5 cm (a
// regression guard; tests/bench/tracker_bench.cc records the exact figure).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "engine/dataset/dataset.h"
#include "engine/eval/ate.h"
#include "engine/eval/trajectory.h"
#include "tests/test_data.h"
#include "tracker/cv_view.h"
#include "tracker/orb_tracker.h"

namespace dypho {
namespace {

using ::dypho::testing::SharedData;

constexpr char kRpy[] = "tum_fr1_rpy_head250";
constexpr double kKinectReadout = 0.025;  // [s] rolling-shutter readout of the Kinect v1 RGB camera

TrackerFrame ToTrackerFrame(const Frame& f) {
  TrackerFrame t;
  t.timestamp = f.timestamp;
  t.image = CvView(f.rgb);
  if (f.has_depth) t.depth = CvView(f.depth);
  return t;
}

struct SequenceRun {
  Trajectory estimate;
  std::vector<TrackStatus> status;
  int keyframes = 0;
  double ate = 0.0;
};

SequenceRun RunRpy(const OrbTrackerOptions& options) {
  const auto dataset = OpenDataset(SharedData(kRpy));
  OrbTracker tracker(dataset->camera(), options);
  SequenceRun run;
  for (size_t i = 0; i < dataset->size(); ++i) {
    const Frame frame = dataset->Load(i);
    const TrackResult r = tracker.Track(ToTrackerFrame(frame));
    run.status.push_back(r.status);
    run.keyframes += r.is_keyframe;
    run.estimate.Add(frame.timestamp, r.cam_from_world.Inverse());
    EXPECT_EQ(r.features.size() > 0, true) << "frame " << i;
  }
  run.ate = ComputeAte(dataset->ground_truth(), run.estimate).translation.rmse;
  return run;
}

TEST(TrackerTum, Fr1RpyEveryFrameTrackedAndAteBelowFiveCentimetres) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  OrbTrackerOptions options;
  options.rolling_shutter_readout = kKinectReadout;
  const SequenceRun run = RunRpy(options);
  int tracked = 0;
  for (size_t i = 0; i < run.status.size(); ++i) {
    tracked += IsTracked(run.status[i]);
    EXPECT_EQ(run.status[i], TrackStatus::kOk) << "frame " << i << ": " << TrackStatusName(run.status[i]);
  }
  std::printf("tum_fr1_rpy_head250: %d of %zu frames tracked, %d keyframes, ATE RMSE %.4f m (rolling shutter %.0f ms)\n",
              tracked, run.status.size(), run.keyframes, run.ate, 1000.0 * kKinectReadout);
  EXPECT_EQ(tracked, static_cast<int>(run.status.size()));
  EXPECT_LT(run.ate, 0.05);
}

// The same without the rolling-shutter model: still every frame tracked; the
// figure shows what the model gains on this camera (the error is mostly the
// rolling shutter's, so only a loose bound is asserted).
TEST(TrackerTum, Fr1RpyWithoutRollingShutterModel) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const SequenceRun run = RunRpy(OrbTrackerOptions());
  int tracked = 0;
  for (TrackStatus s : run.status) tracked += IsTracked(s);
  std::printf("tum_fr1_rpy_head250 without the rolling-shutter model: %d of %zu frames tracked, ATE RMSE %.4f m\n",
              tracked, run.status.size(), run.ate);
  EXPECT_EQ(tracked, static_cast<int>(run.status.size()));
  EXPECT_LT(run.ate, 0.10);
}

// The same poses, bit for bit, whatever the number of OpenCV threads (the
// pyramid levels run in parallel).
TEST(TrackerTum, DeterministicForAnyThreadCount) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  std::vector<Frame> frames;
  for (size_t i = 0; i < 40; ++i) frames.push_back(dataset->Load(i));
  const int threads = cv::getNumThreads();
  std::vector<std::vector<Rigid3d>> poses;
  for (int n : {1, 2}) {
    cv::setNumThreads(n);
    OrbTrackerOptions options;
    options.rolling_shutter_readout = kKinectReadout;
    OrbTracker tracker(dataset->camera(), options);
    poses.emplace_back();
    for (const Frame& f : frames) poses.back().push_back(tracker.Track(ToTrackerFrame(f)).cam_from_world);
  }
  cv::setNumThreads(threads);
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(poses[0][i].translation, poses[1][i].translation) << "frame " << i;
    EXPECT_EQ(poses[0][i].rotation.coeffs(), poses[1][i].rotation.coeffs()) << "frame " << i;
  }
}

}  // namespace
}  // namespace dypho
