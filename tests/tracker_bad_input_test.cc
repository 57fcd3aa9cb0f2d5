// The ORB tracker on bad input, on real TUM fr1/rpy frames: invalid frames
// throw InvalidInput naming the field (and leave the tracker usable); no
// depth before the map exists waits (kInitializing); frames without valid
// depth are tracked from 2D matches; black frames and a frame from another
// scene are lost (never a confident wrong pose) and tracking recovers by
// relocalisation; a sudden jump inside the scene is either tracked
// correctly or lost, then recovered. Never a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/check.h"
#include "engine/dataset/dataset.h"
#include "tests/test_data.h"
#include "tracker/cv_view.h"
#include "tracker/orb_tracker.h"

namespace dypho {
namespace {

using ::dypho::testing::SharedData;

constexpr char kRpy[] = "tum_fr1_rpy_head250";
constexpr char kWalking[] = "tum_fr3_walking_xyz_3frames";
// A "correct" pose: the tracker's error on these fast rotations reaches a few
// centimetres and degrees (the ATE over the sequence is about 1.3 cm); a
// wrong pose is off by much more.
constexpr double kMaxCentreError = 0.08;  // [m]
constexpr double kMaxAngleError = 0.1;    // [rad] about 6 degrees

// Frames of fr1/rpy decoded once for every test of this file.
class RpyFrames {
 public:
  static RpyFrames& Get() {
    static RpyFrames frames;
    return frames;
  }
  const Camera& camera() const { return dataset_->camera(); }
  const Frame& operator[](size_t i) {
    auto it = cache_.find(i);
    if (it == cache_.end()) it = cache_.emplace(i, dataset_->Load(i)).first;
    return it->second;
  }

 private:
  RpyFrames() : dataset_(OpenDataset(SharedData(kRpy))) {}
  std::unique_ptr<Dataset> dataset_;
  std::map<size_t, Frame> cache_;
};

OrbTrackerOptions Options() {
  OrbTrackerOptions o;
  o.rolling_shutter_readout = 0.025;  // Kinect v1
  return o;
}

TrackerFrame ToTrackerFrame(const Frame& f) {
  TrackerFrame t;
  t.timestamp = f.timestamp;
  t.image = CvView(f.rgb);
  if (f.has_depth) t.depth = CvView(f.depth);
  return t;
}

// Ground-truth cam_from_world of frame `i` in the tracker's world (the camera
// of frame `origin`, where the map started).
Rigid3d Expected(RpyFrames& frames, size_t i, size_t origin) {
  return frames[i].world_from_cam_gt->Inverse() * *frames[origin].world_from_cam_gt;
}

bool Close(const Rigid3d& a, const Rigid3d& b) {
  return (a.Inverse().translation - b.Inverse().translation).norm() < kMaxCentreError &&
         RotationAngle(a.rotation, b.rotation) < kMaxAngleError;
}

std::string Describe(const Rigid3d& a, const Rigid3d& b) {
  char text[128];
  std::snprintf(text, sizeof(text), "centre error %.3f m, rotation error %.2f deg",
                (a.Inverse().translation - b.Inverse().translation).norm(),
                RotationAngle(a.rotation, b.rotation) * 180.0 / M_PI);
  return text;
}

// Tracks frames [first, last] normally and expects each to be tracked correctly.
void TrackRange(OrbTracker* tracker, RpyFrames& frames, size_t first, size_t last, size_t origin) {
  for (size_t i = first; i <= last; ++i) {
    const TrackResult r = tracker->Track(ToTrackerFrame(frames[i]));
    ASSERT_TRUE(IsTracked(r.status)) << "frame " << i << ": " << TrackStatusName(r.status) << " " << r.message;
    ASSERT_TRUE(Close(r.cam_from_world, Expected(frames, i, origin)))
        << "frame " << i << ": " << Describe(r.cam_from_world, Expected(frames, i, origin));
  }
}

void ExpectInvalid(const std::function<void()>& f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "expected InvalidInput mentioning '" << part << "'";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(TrackerBadInput, OptionsAreValidatedNamingTheField) {
  OrbTrackerOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error)) << error;
  o.min_inliers = 2;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("min_inliers"), std::string::npos) << error;
  o = OrbTrackerOptions();
  o.extractor.num_levels = 0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("extractor"), std::string::npos) << error;
  EXPECT_NE(error.find("num_levels"), std::string::npos) << error;
  o = OrbTrackerOptions();
  o.optimizer.virtual_baseline = 0.0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("virtual_baseline"), std::string::npos) << error;
  o = OrbTrackerOptions();
  o.loops.verification.min_inliers = 2;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("LoopClosingOptions.verification"), std::string::npos) << error;
  EXPECT_NE(error.find("min_inliers"), std::string::npos) << error;
  o = OrbTrackerOptions();
  o.loops.min_keyframes = 1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("LoopClosingOptions.min_keyframes"), std::string::npos) << error;
  ExpectInvalid([&] { OrbTracker tracker{Camera(), OrbTrackerOptions()}; }, "camera");
}

TEST(TrackerBadInput, InvalidFramesThrowNamingTheFieldAndLeaveTheTrackerUsable) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  RpyFrames& frames = RpyFrames::Get();
  OrbTracker tracker(frames.camera(), Options());
  TrackRange(&tracker, frames, 0, 5, 0);
  const TrackerFrame good = ToTrackerFrame(frames[6]);
  TrackerFrame bad = good;
  bad.image = cv::Mat();
  ExpectInvalid([&] { tracker.Track(bad); }, "image is empty");
  bad = good;
  bad.image = cv::Mat(240, 320, CV_8UC3, cv::Scalar(0, 0, 0));
  ExpectInvalid([&] { tracker.Track(bad); }, "image is 320x240 but the camera is 640x480");
  bad = good;
  bad.image = cv::Mat(480, 640, CV_8UC4, cv::Scalar(0, 0, 0, 0));
  ExpectInvalid([&] { tracker.Track(bad); }, "image must be CV_8UC3");
  bad = good;
  good.depth.convertTo(bad.depth, CV_16U, 5000.0);
  ExpectInvalid([&] { tracker.Track(bad); }, "depth must be CV_32FC1");
  bad = good;
  bad.depth = good.depth(cv::Rect(0, 0, 600, 480));
  ExpectInvalid([&] { tracker.Track(bad); }, "depth is 600x480");
  bad = good;
  bad.dynamic_mask = cv::Mat(480, 640, CV_32FC1, cv::Scalar(0));
  ExpectInvalid([&] { tracker.Track(bad); }, "dynamic_mask must be CV_8UC1");
  bad = good;
  bad.static_weight = cv::Mat(480, 320, CV_32FC1, cv::Scalar(1));
  ExpectInvalid([&] { tracker.Track(bad); }, "static_weight is 320x480");
  bad = good;
  bad.timestamp = std::numeric_limits<double>::quiet_NaN();
  ExpectInvalid([&] { tracker.Track(bad); }, "timestamp");
  // The tracker goes on as if nothing happened.
  TrackRange(&tracker, frames, 6, 12, 0);
}

TEST(TrackerBadInput, WithoutDepthTheMapWaitsThenStarts) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  RpyFrames& frames = RpyFrames::Get();
  OrbTracker tracker(frames.camera(), Options());
  for (size_t i = 0; i < 3; ++i) {
    TrackerFrame f = ToTrackerFrame(frames[i]);
    f.depth = cv::Mat();  // no depth image at all
    const TrackResult r = tracker.Track(f);
    EXPECT_EQ(r.status, TrackStatus::kInitializing) << i;
    EXPECT_NE(r.message.find("features with depth"), std::string::npos) << r.message;
    EXPECT_TRUE(r.cam_from_world.translation.isZero());
  }
  {
    TrackerFrame f = ToTrackerFrame(frames[3]);
    cv::Mat nan_depth(480, 640, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    f.depth = nan_depth;  // a depth image without a single valid reading
    EXPECT_EQ(tracker.Track(f).status, TrackStatus::kInitializing);
  }
  const TrackResult first = tracker.Track(ToTrackerFrame(frames[4]));
  EXPECT_EQ(first.status, TrackStatus::kOk);
  EXPECT_TRUE(first.is_keyframe);
  EXPECT_EQ(tracker.num_keyframes(), 1);
  EXPECT_GT(tracker.num_map_points(), 100);
  TrackRange(&tracker, frames, 5, 30, 4);
}

// Frames whose depth is missing, zero, NaN, infinite or negative are tracked
// from their 2D matches against the existing map (no keyframe can be made
// without depth, so this lasts while the view overlaps the map).
TEST(TrackerBadInput, FramesWithoutValidDepthAreTrackedFromTheMap) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  RpyFrames& frames = RpyFrames::Get();
  OrbTracker tracker(frames.camera(), Options());
  TrackRange(&tracker, frames, 0, 30, 0);
  const float kInvalid[] = {0.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                            -1.0f};
  for (size_t i = 31; i <= 36; ++i) {
    TrackerFrame f = ToTrackerFrame(frames[i]);
    cv::Mat depth;
    if (i % 5 != 4) depth = cv::Mat(480, 640, CV_32FC1, cv::Scalar(kInvalid[i % 4]));
    f.depth = depth;
    const TrackResult r = tracker.Track(f);
    EXPECT_TRUE(IsTracked(r.status)) << "frame " << i << ": " << r.message;
    EXPECT_TRUE(Close(r.cam_from_world, Expected(frames, i, 0)))
        << "frame " << i << ": " << Describe(r.cam_from_world, Expected(frames, i, 0));
    for (const TrackedFeature& feature : r.features) EXPECT_EQ(feature.depth, 0.0f);
  }
  TrackRange(&tracker, frames, 37, 60, 0);
}

TEST(TrackerBadInput, BlackFramesAreLostThenTrackingIsRecovered) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  RpyFrames& frames = RpyFrames::Get();
  OrbTracker tracker(frames.camera(), Options());
  TrackRange(&tracker, frames, 0, 59, 0);
  const Rigid3d last = tracker.Track(ToTrackerFrame(frames[60])).cam_from_world;
  const cv::Mat black(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
  for (size_t i = 61; i <= 64; ++i) {
    TrackerFrame f = ToTrackerFrame(frames[i]);
    f.image = black;  // depth stays valid: the colour camera failed
    const TrackResult r = tracker.Track(f);
    EXPECT_EQ(r.status, TrackStatus::kLost) << i;
    EXPECT_FALSE(r.message.empty());
    EXPECT_EQ(r.features.size(), 0u);
    EXPECT_TRUE(r.cam_from_world.translation.isApprox(last.translation) &&
                r.cam_from_world.rotation.isApprox(last.rotation))
        << "a lost frame repeats the last pose";
  }
  const TrackResult back = tracker.Track(ToTrackerFrame(frames[65]));
  EXPECT_EQ(back.status, TrackStatus::kRelocalized) << back.message;
  EXPECT_TRUE(Close(back.cam_from_world, Expected(frames, 65, 0))) << Describe(back.cam_from_world, Expected(frames, 65, 0));
  TrackRange(&tracker, frames, 66, 90, 0);
}

// A frame of another scene (TUM fr3/walking) is lost, not tracked with a
// made-up pose; the next frames of the sequence relocalise.
TEST(TrackerBadInput, AFrameOfAnotherSceneIsLostThenRelocalised) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  DYPHO_REQUIRE_SHARED_DATA(kWalking);
  RpyFrames& frames = RpyFrames::Get();
  const auto walking = OpenDataset(SharedData(kWalking));
  Frame other;
  for (size_t i = 0; i < walking->size(); ++i) {
    other = walking->Load(i);
    if (other.has_depth) break;
  }
  ASSERT_TRUE(other.has_depth);
  OrbTracker tracker(frames.camera(), Options());
  TrackRange(&tracker, frames, 0, 99, 0);
  TrackerFrame f = ToTrackerFrame(other);
  f.timestamp = frames[100].timestamp;
  const TrackResult r = tracker.Track(f);
  EXPECT_EQ(r.status, TrackStatus::kLost) << "a frame of another scene must not get a pose";
  const TrackResult back = tracker.Track(ToTrackerFrame(frames[101]));
  EXPECT_EQ(back.status, TrackStatus::kRelocalized) << back.message;
  EXPECT_TRUE(Close(back.cam_from_world, Expected(frames, 101, 0))) << Describe(back.cam_from_world, Expected(frames, 101, 0));
  TrackRange(&tracker, frames, 102, 120, 0);
}

// A sudden jump inside the scene (frames 100 -> 200, a large rotation): the
// frame is either tracked correctly (descriptor matching against the
// keyframes) or lost; never tracked with a wrong pose. Tracking continues
// correctly afterwards.
TEST(TrackerBadInput, ASuddenJumpIsTrackedCorrectlyOrLostNeverWrong) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  RpyFrames& frames = RpyFrames::Get();
  OrbTracker tracker(frames.camera(), Options());
  TrackRange(&tracker, frames, 0, 100, 0);
  const Rigid3d before = Expected(frames, 100, 0), after = Expected(frames, 200, 0);
  std::printf("jump 100 -> 200: the camera turns by %.1f deg\n",
              RotationAngle(before.rotation, after.rotation) * 180.0 / M_PI);
  int tracked_after_jump = 0;
  for (size_t i = 200; i <= 230; ++i) {
    const TrackResult r = tracker.Track(ToTrackerFrame(frames[i]));
    if (i <= 202) std::printf("  frame %zu: %s %s\n", i, TrackStatusName(r.status), r.message.c_str());
    if (IsTracked(r.status)) {
      ++tracked_after_jump;
      EXPECT_TRUE(Close(r.cam_from_world, Expected(frames, i, 0)))
          << "frame " << i << " " << TrackStatusName(r.status) << ": " << Describe(r.cam_from_world, Expected(frames, i, 0));
    } else {
      EXPECT_EQ(r.status, TrackStatus::kLost);
    }
  }
  EXPECT_GT(tracked_after_jump, 20) << "tracking should recover after the jump";
}

TEST(TrackerBadInput, ResetStartsANewMap) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  RpyFrames& frames = RpyFrames::Get();
  OrbTracker tracker(frames.camera(), Options());
  TrackRange(&tracker, frames, 0, 10, 0);
  tracker.Reset();
  EXPECT_EQ(tracker.num_keyframes(), 0);
  const TrackResult r = tracker.Track(ToTrackerFrame(frames[20]));
  EXPECT_EQ(r.status, TrackStatus::kOk);
  EXPECT_TRUE(r.is_keyframe);
  EXPECT_TRUE(r.cam_from_world.translation.isZero());
  TrackRange(&tracker, frames, 21, 30, 20);
}

}  // namespace
}  // namespace dypho
