// Sparse stereo depth of the tracker's features (tracker/stereo/stereo_features.h):
// exact disparities on a synthetic shifted pair, agreement with the dense
// disparity on real KITTI pairs, and the ORB tracker on kitti_stereo_51 with
// no depth image at all.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <gtest/gtest.h>

#include "common/check.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/ate.h"
#include "engine/pipeline/pipeline_options.h"
#include "engine/stereo/disparity.h"
#include "engine/stereo/rig.h"
#include "tests/test_data.h"
#include "tracker/orb_extractor.h"
#include "tracker/orb_tracker.h"
#include "tracker/stereo/stereo_features.h"

namespace dypho {
namespace {

// Smooth random texture (blurred noise), 8-bit.
cv::Mat Texture(int w, int h, unsigned seed) {
  cv::Mat noise(h, w, CV_8U);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat blurred;
  cv::GaussianBlur(noise, blurred, cv::Size(0, 0), 1.5);
  cv::normalize(blurred, blurred, 0, 255, cv::NORM_MINMAX);
  return blurred;
}

Camera TestCamera(int w, int h) {
  Camera c;
  c.width = w, c.height = h, c.fx = c.fy = 400, c.cx = w / 2.0, c.cy = h / 2.0;
  return c;
}

TEST(StereoFeatures, ShiftedPairGivesTheExactDisparity) {
  const int w = 480, h = 320, shift = 12;
  const cv::Mat wide = Texture(w + shift, h, 3);
  const cv::Mat left = wide(cv::Rect(0, 0, w, h)).clone();        // left(u) = wide(u)
  const cv::Mat right = wide(cv::Rect(shift, 0, w, h)).clone();   // right(u) = wide(u + shift): a match at u - shift
  const Camera camera = TestCamera(w, h);
  OrbExtractorOptions eo;
  eo.num_features = 800;
  OrbExtractor extractor(eo, camera);
  const OrbFeatures fl = extractor.Extract(left), fr = extractor.Extract(right);
  StereoFeatureOptions o;
  o.baseline = 0.1;
  StereoFeatureStats stats;
  const std::vector<float> depth = StereoFeatureDepths(fl, fr, left, right, camera.fx, eo.scale_factor, o, &stats);
  ASSERT_EQ(depth.size(), fl.size());
  const double expected = camera.fx * o.baseline / shift;
  int with_depth = 0, wrong = 0;
  for (size_t i = 0; i < depth.size(); ++i) {
    if (depth[i] <= 0) continue;
    ++with_depth;
    if (std::abs(camera.fx * o.baseline / depth[i] - shift) > 0.25) ++wrong;
  }
  std::printf("%zu left features, %d right, %d with depth (%d off by > 0.25 px); depth %.4f m expected\n", fl.size(),
              stats.right, with_depth, wrong, expected);
  EXPECT_EQ(stats.matched, with_depth);
  EXPECT_GT(with_depth, 0.6 * fl.size());
  EXPECT_LE(wrong, 0.01 * with_depth);
}

TEST(StereoFeatures, NoMatchOutsideTheDisparityRange) {
  const int w = 480, h = 320, shift = 40;
  const cv::Mat wide = Texture(w + shift, h, 5);
  const cv::Mat left = wide(cv::Rect(0, 0, w, h)).clone(), right = wide(cv::Rect(shift, 0, w, h)).clone();
  const Camera camera = TestCamera(w, h);
  OrbExtractor extractor(OrbExtractorOptions(), camera);
  const OrbFeatures fl = extractor.Extract(left), fr = extractor.Extract(right);
  StereoFeatureOptions o;
  o.baseline = 0.1;
  o.max_disparity = 30;  // the true disparity (40) is outside
  StereoFeatureStats stats;
  StereoFeatureDepths(fl, fr, left, right, camera.fx, 1.2, o, &stats);
  EXPECT_LE(stats.matched, 0.02 * fl.size()) << "matches to wrong features";
}

TEST(StereoFeatures, BadOptionsAndRightImageAreErrors) {
  StereoFeatureOptions o;
  std::string error;
  o.baseline = -0.1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("baseline"), std::string::npos) << error;
  o.baseline = 0.1;
  o.window_px = 4;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("window_px"), std::string::npos) << error;
  const Camera camera = TestCamera(160, 120);
  OrbTrackerOptions options;
  options.stereo.baseline = 0.1;
  OrbTracker tracker(camera, options);
  TrackerFrame frame;
  frame.image = Texture(160, 120, 1);
  frame.right_image = Texture(80, 60, 2);
  try {
    tracker.Track(frame);
    ADD_FAILURE() << "a right image of the wrong size was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("right_image"), std::string::npos) << e.what();
  }
}

// The rectified KITTI pair i (grey).
std::pair<cv::Mat, cv::Mat> KittiPair(size_t i) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06zu.png", i);
  const std::string root = testing::SharedData("kitti_stereo_51");
  return {cv::imread(root + "/image_0/" + name, cv::IMREAD_GRAYSCALE),
          cv::imread(root + "/image_1/" + name, cv::IMREAD_GRAYSCALE)};
}

TEST(StereoFeatures, KittiFeatureDepthsAgreeWithTheDenseDisparity) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const auto dataset = OpenDataset(testing::SharedData("kitti_stereo_51"));
  ASSERT_NE(dataset->stereo(), nullptr);
  const Camera& camera = dataset->camera();
  const OrbTrackerOptions to = PresetOptions("stereo").tracker;
  OrbExtractor extractor(to.extractor, camera);
  StereoFeatureOptions o = to.stereo;
  o.baseline = dataset->stereo()->baseline;
  std::vector<double> rel;
  long features = 0, matched = 0;
  for (size_t i : {0, 25, 50}) {
    const auto [left, right] = KittiPair(i);
    ASSERT_FALSE(left.empty() || right.empty());
    const OrbFeatures fl = extractor.Extract(left), fr = extractor.Extract(right);
    const std::vector<float> depth = StereoFeatureDepths(fl, fr, left, right, camera.fx, to.extractor.scale_factor, o);
    const stereo::DisparityResult dense = stereo::ComputeDisparity(left, right, stereo::DisparityOptions());
    for (size_t k = 0; k < fl.size(); ++k) {
      ++features;
      if (depth[k] <= 0) continue;
      ++matched;
      const int x = cvRound(fl.keypoints[k].pt.x), y = cvRound(fl.keypoints[k].pt.y);
      const float d = dense.disparity.at<float>(y, x);
      if (!dense.valid.at<uint8_t>(y, x) || dense.confidence.at<float>(y, x) <= 0 || d < 1) continue;
      const double d_sparse = camera.fx * o.baseline / depth[k];
      rel.push_back(std::abs(d_sparse - d));
    }
  }
  ASSERT_GT(rel.size(), 100u);
  std::sort(rel.begin(), rel.end());
  const double median = rel[rel.size() / 2], p90 = rel[rel.size() * 9 / 10];
  std::printf("%ld features, %ld with a sparse depth; against the dense disparity at %zu of them: median %.3f px, 90th "
              "percentile %.3f px\n", features, matched, rel.size(), median, p90);
  EXPECT_GT(matched, 0.3 * features);
  EXPECT_LT(median, 0.5);
  EXPECT_LT(p90, 2.0);
}

TEST(StereoFeatures, KittiTrackedWithoutADepthImage) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const auto dataset = OpenDataset(testing::SharedData("kitti_stereo_51"));
  OrbTrackerOptions options = PresetOptions("stereo").tracker;
  options.stereo.baseline = dataset->stereo()->baseline;
  OrbTracker tracker(dataset->camera(), options);
  Trajectory estimate;
  std::vector<double> ms;
  for (size_t i = 0; i < dataset->size(); ++i) {
    const auto [left, right] = KittiPair(i);
    TrackerFrame input;
    input.timestamp = dataset->info(i).timestamp;
    input.image = left;
    input.right_image = right;
    const TrackResult r = tracker.Track(input);
    ms.push_back(r.timing.total_ms);
    EXPECT_TRUE(r.status == TrackStatus::kOk || (i == 0 && r.status == TrackStatus::kInitializing))
        << "frame " << i << ": " << TrackStatusName(r.status) << " " << r.message;
    if (r.status == TrackStatus::kOk) estimate.Add(input.timestamp, r.cam_from_world.Inverse());
  }
  const Trajectory& gt = dataset->ground_truth();
  double path = 0;
  for (size_t i = 1; i < gt.size(); ++i) path += (gt.world_from_cam[i].translation - gt.world_from_cam[i - 1].translation).norm();
  const AteResult ate = ComputeAte(gt, estimate);
  std::sort(ms.begin(), ms.end());
  std::printf("no depth image: %zu frames tracked, ATE %.3f m (%.2f %% of %.1f m); Track median %.1f ms\n",
              estimate.size(), ate.translation.rmse, 100 * ate.translation.rmse / path, path, ms[ms.size() / 2]);
  // Measured: all 51 frames, ATE 0.468 m (0.90 % of 51.8 m; the dense
  // disparity as the depth image gives 1.05 %), Track median 31.6 ms.
  EXPECT_LT(ate.translation.rmse, 0.0125 * path);
}

}  // namespace
}  // namespace dypho
