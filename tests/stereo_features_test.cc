// Sparse stereo depth of the tracker's features (tracker/stereo/stereo_features.h):
// exact disparities on a synthetic shifted pair, agreement with the dense
// disparity on real KITTI pairs, and the ORB tracker on kitti_stereo_51 with
// no depth image at all; the same with the half-resolution preview depth as
// the prior of the row search (StereoFeatureDepthsFromPrior).
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
#include "engine/stereo/pair_depth.h"
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

Camera TestCamera(int w, int h) { return Camera{400, 400, w / 2.0, h / 2.0, w, h}; }

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

// The prior's search: exact disparities on the shifted pair from a prior
// up to prior_search_px off; none when the prior is further off (the best
// shift is at the end of the range) or missing; a prior of the wrong size
// is an error naming it.
TEST(StereoFeatures, PriorSearchFindsTheShiftNearThePrior) {
  const int w = 480, h = 320, shift = 12;
  const cv::Mat wide = Texture(w + shift, h, 3);
  const cv::Mat left = wide(cv::Rect(0, 0, w, h)).clone();
  const cv::Mat right = wide(cv::Rect(shift, 0, w, h)).clone();
  const Camera camera = TestCamera(w, h);
  OrbExtractorOptions eo;
  eo.num_features = 800;
  OrbExtractor extractor(eo, camera);
  const OrbFeatures fl = extractor.Extract(left);
  StereoFeatureOptions o;
  o.baseline = 0.1;
  o.prior_search_px = 3;
  auto prior_at = [&](double disparity, int n) {
    return cv::Mat(h / n, w / n, CV_32F, cv::Scalar(camera.fx * o.baseline / disparity));
  };
  for (double prior_disparity : {12.0, 10.0, 14.5}) {
    for (int n : {1, 2}) {
      StereoFeatureStats stats;
      const std::vector<float> depth =
          StereoFeatureDepthsFromPrior(fl, prior_at(prior_disparity, n), left, right, camera.fx, o, &stats);
      int with_depth = 0, wrong = 0;
      for (float z : depth) {
        if (z <= 0) continue;
        ++with_depth;
        if (std::abs(camera.fx * o.baseline / z - shift) > 0.1) ++wrong;
      }
      EXPECT_EQ(stats.matched, with_depth);
      EXPECT_EQ(stats.right, 0);
      EXPECT_GT(with_depth, 0.8 * fl.size()) << "prior " << prior_disparity << ", 1/" << n;
      EXPECT_EQ(wrong, 0) << "prior " << prior_disparity << ", 1/" << n;
    }
  }
  // 5 px off with a 3 px search: the true shift is outside the range.
  int far_off = 0;
  for (float z : StereoFeatureDepthsFromPrior(fl, prior_at(17.0, 1), left, right, camera.fx, o)) far_off += z > 0;
  EXPECT_LE(far_off, 0.02 * fl.size()) << "depths from a prior 5 px off";
  // No prior (zeros): no depth.
  for (float z : StereoFeatureDepthsFromPrior(fl, cv::Mat::zeros(h, w, CV_32F), left, right, camera.fx, o))
    EXPECT_EQ(z, 0.0f);
  try {
    StereoFeatureDepthsFromPrior(fl, cv::Mat::zeros(h / 3 + 1, w / 3, CV_32F), left, right, camera.fx, o);
    ADD_FAILURE() << "a prior whose size does not divide the image's was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("prior"), std::string::npos) << e.what();
  }
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
  frame.right_image = Texture(160, 120, 2);
  frame.stereo_prior_depth = cv::Mat::zeros(50, 70, CV_32F);
  try {
    tracker.Track(frame);
    ADD_FAILURE() << "a depth prior whose size does not divide the camera's was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("stereo_prior_depth"), std::string::npos) << e.what();
  }
  o = StereoFeatureOptions();
  o.prior_search_px = 0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("prior_search_px"), std::string::npos) << error;
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

// Seven KITTI pairs: the feature depths from right-image features and from
// the half-resolution preview as the prior, against the full-resolution
// dense disparity (the prior's own source at 4x the pixels).
TEST(StereoFeatures, KittiPriorFeatureDepthsAgreeWithTheDenseDisparity) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const auto dataset = OpenDataset(testing::SharedData("kitti_stereo_51"));
  const stereo::StereoRig& rig = *dataset->stereo();
  const Camera& camera = dataset->camera();
  const OrbTrackerOptions to = PresetOptions("stereo").tracker;
  OrbExtractor extractor(to.extractor, camera);
  StereoFeatureOptions o = to.stereo;
  o.baseline = rig.baseline;
  long matched_by_method[2] = {0, 0};
  for (int method = 0; method < 2; ++method) {
    std::vector<double> err;
    long features = 0, matched = 0, far = 0;
    for (size_t i : {0, 10, 20, 25, 30, 40, 50}) {
      const auto [left, right] = KittiPair(i);
      const OrbFeatures fl = extractor.Extract(left);
      std::vector<float> depth;
      if (method == 0) {
        depth = StereoFeatureDepths(fl, extractor.Extract(right), left, right, camera.fx, to.extractor.scale_factor, o);
      } else {
        const cv::Mat prior = stereo::PairDepth(left, right, rig.disparity, camera.fx, rig.baseline,
                                                rig.min_disparity_for_depth, 2);
        depth = StereoFeatureDepthsFromPrior(fl, prior, left, right, camera.fx, o);
      }
      const stereo::DisparityResult dense = stereo::ComputeDisparity(left, right, rig.disparity);
      for (size_t k = 0; k < fl.size(); ++k) {
        ++features;
        if (depth[k] <= 0) continue;
        ++matched;
        if (depth[k] > to.max_depth) { ++far; continue; }
        const int x = cvRound(fl.keypoints[k].pt.x), y = cvRound(fl.keypoints[k].pt.y);
        const float d = dense.disparity.at<float>(y, x);
        if (!dense.valid.at<uint8_t>(y, x) || dense.confidence.at<float>(y, x) <= 0 || d < 1) continue;
        err.push_back(std::abs(camera.fx * o.baseline / depth[k] - d));
      }
    }
    ASSERT_GT(err.size(), 500u);
    std::sort(err.begin(), err.end());
    const double median = err[err.size() / 2], p90 = err[err.size() * 9 / 10];
    const double over2 = double(err.end() - std::upper_bound(err.begin(), err.end(), 2.0)) / err.size();
    std::printf("%s: %ld features, %ld with a depth (%ld beyond the tracker's max_depth); against the full dense "
                "disparity at %zu of them: median %.3f px, 90th percentile %.3f px, %.2f %% over 2 px\n",
                method ? "depth prior" : "right-image features", features, matched, far, err.size(), median, p90,
                100 * over2);
    matched_by_method[method] = matched;
    EXPECT_LT(median, 0.5);
    EXPECT_LT(p90, method ? 1.5 : 2.0);
    if (method == 1) EXPECT_LT(over2, 0.05);
  }
  // Measured: right-image features 6966 of 13999 with a depth, 7.3 % of
  // them over 2 px; the prior 10853, 2.1 % over 2 px.
  EXPECT_GT(matched_by_method[1], matched_by_method[0]);
}

// The tracker on kitti_stereo_51 with the right image only (right-image ORB
// features) or with the right image and the half-resolution preview depth
// as the prior of the row search.
// Returns the mean coarse-stage matches of the frames whose coarse pose came
// from the last frame. `last_frame_points` < 0: the preset's.
double TrackKitti(bool with_prior, int last_frame_points = -1) {
  const auto dataset = OpenDataset(testing::SharedData("kitti_stereo_51"));
  const stereo::StereoRig& rig = *dataset->stereo();
  OrbTrackerOptions options = PresetOptions("stereo").tracker;
  options.stereo.baseline = rig.baseline;
  if (last_frame_points >= 0) options.last_frame_points = last_frame_points;
  OrbTracker tracker(dataset->camera(), options);
  Trajectory estimate;
  std::vector<double> ms;
  double coarse_matches = 0;
  int coarse_frames = 0;
  for (size_t i = 0; i < dataset->size(); ++i) {
    const auto [left, right] = KittiPair(i);
    TrackerFrame input;
    input.timestamp = dataset->info(i).timestamp;
    input.image = left;
    input.right_image = right;
    if (with_prior)
      input.stereo_prior_depth = stereo::PairDepth(left, right, rig.disparity, dataset->camera().fx, rig.baseline,
                                                   rig.min_disparity_for_depth, 2);
    const TrackResult r = tracker.Track(input);
    ms.push_back(r.timing.total_ms);
    if (r.coarse_source == CoarseSource::kLastFrame) coarse_matches += r.coarse_matches, ++coarse_frames;
    EXPECT_TRUE(r.status == TrackStatus::kOk || (i == 0 && r.status == TrackStatus::kInitializing))
        << "frame " << i << ": " << TrackStatusName(r.status) << " " << r.message;
    if (r.status == TrackStatus::kOk) estimate.Add(input.timestamp, r.cam_from_world.Inverse());
  }
  const Trajectory& gt = dataset->ground_truth();
  double path = 0;
  for (size_t i = 1; i < gt.size(); ++i) path += (gt.world_from_cam[i].translation - gt.world_from_cam[i - 1].translation).norm();
  const AteResult ate = ComputeAte(gt, estimate);
  AteOptions with_scale;
  with_scale.estimate_scale = true;
  const AteResult sim3 = ComputeAte(gt, estimate, with_scale);
  std::sort(ms.begin(), ms.end());
  std::printf("%s, %d last-frame points: %zu frames tracked, ATE %.3f m (%.2f %% of %.1f m); Track median %.1f ms; "
              "%.1f coarse matches on the %d frames placed from the last frame\n",
              with_prior ? "right image and depth prior" : "right image only", options.last_frame_points,
              estimate.size(), ate.translation.rmse, 100 * ate.translation.rmse / path, path, ms[ms.size() / 2],
              coarse_matches / std::max(1, coarse_frames), coarse_frames);
  std::printf("  with Sim(3) alignment: ATE %.3f m (%.2f %%), scale %.4f\n", sim3.translation.rmse,
              100 * sim3.translation.rmse / path, sim3.scale);
  // Measured: all 51 frames, ATE 0.468 m (0.90 % of 51.8 m; the dense
  // disparity as the depth image gives 1.05 %) with right-image features,
  // 0.502-0.505 m with the prior (0 or 200 last-frame points).
  EXPECT_LT(ate.translation.rmse, 0.0125 * path);
  // Nearly all of that is scale: the stereo depth of this sequence (every
  // method, also OpenCV's SGBM) gives a path 3-4 % longer than the ground
  // truth's (BENCHMARKS.md, "The scale of kitti_stereo_51").
  EXPECT_LT(sim3.translation.rmse, 0.004 * path);  // measured 0.22-0.28 %
  return coarse_matches / std::max(1, coarse_frames);
}

TEST(StereoFeatures, KittiTrackedWithoutADepthImage) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  TrackKitti(false);
}

TEST(StereoFeatures, KittiTrackedWithADepthPrior) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  TrackKitti(true);
}

// The last frame's temporary points (OrbTrackerOptions::last_frame_points)
// give the coarse stage more matches.
TEST(StereoFeatures, KittiLastFramePointsRaiseTheCoarseMatches) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const double without = TrackKitti(true, 0), with = TrackKitti(true, 200);
  EXPECT_GT(with, 1.3 * without);
}

}  // namespace
}  // namespace dypho
