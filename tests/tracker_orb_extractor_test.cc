// ORB extraction: feature count and spread on real TUM frames, the dynamic
// mask (no feature inside; the adaptive threshold keeps the count when 40%
// of the image is masked, the fixed threshold does not), soft-mask weights,
// undistortion, descriptors that match true correspondences, bad input.
#include "tracker/orb_extractor.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <utility>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/dataset/dataset.h"
#include "tests/test_data.h"
#include "tracker/cv_view.h"
#include "tracker/orb_matcher.h"

namespace dypho {
namespace {

using ::dypho::testing::SharedData;

constexpr char kRpy[] = "tum_fr1_rpy_head250";

cv::Mat Gray(const Frame& frame) {
  cv::Mat gray;
  cv::cvtColor(CvView(frame.rgb), gray, cv::COLOR_RGB2GRAY);
  return gray;
}

// A synthetic textured image: random blocks, blurred a little.
cv::Mat TexturedImage(int width, int height, int seed) {
  cv::Mat image(height, width, CV_8UC1);
  cv::RNG rng(seed);
  for (int y = 0; y < height; y += 8)
    for (int x = 0; x < width; x += 8)
      image(cv::Rect(x, y, std::min(8, width - x), std::min(8, height - y))).setTo(rng.uniform(0, 256));
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

Camera PlainCamera(int width, int height) {
  return Camera{500.0, 500.0, (width - 1) / 2.0, (height - 1) / 2.0, width, height};
}

TEST(OrbExtractorOptions, IsValidNamesTheField) {
  OrbExtractorOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error)) << error;
  o.scale_factor = 1.0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("scale_factor"), std::string::npos) << error;
  o = OrbExtractorOptions();
  o.min_fast_threshold = 9;  // above the fallback threshold 7
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("min_fast_threshold"), std::string::npos) << error;
  EXPECT_THROW(OrbExtractor(o, PlainCamera(64, 48)), InvalidInput);
}

TEST(OrbExtractor, AdaptiveThresholdFormula) {
  // t_c = max(t_min, round(t * (s_g * s_c)^alpha))
  EXPECT_EQ(OrbExtractor::AdaptiveThreshold(20, 1.0, 1.0, 1.0, 5), 20);
  EXPECT_EQ(OrbExtractor::AdaptiveThreshold(20, 0.6, 1.0, 1.0, 5), 12);
  EXPECT_EQ(OrbExtractor::AdaptiveThreshold(20, 0.6, 0.5, 1.0, 5), 6);
  EXPECT_EQ(OrbExtractor::AdaptiveThreshold(20, 0.6, 0.5, 0.5, 5), 11);  // 20 * sqrt(0.3) = 10.95
  EXPECT_EQ(OrbExtractor::AdaptiveThreshold(20, 0.1, 0.1, 1.0, 5), 5);   // bounded below
  EXPECT_EQ(OrbExtractor::AdaptiveThreshold(7, 0.6, 1.0, 0.0, 5), 7);    // alpha = 0: no relaxation
}

TEST(OrbExtractor, BadInputThrowsNamingTheArgument) {
  const Camera camera = PlainCamera(160, 120);
  OrbExtractor extractor(OrbExtractorOptions(), camera);
  auto expect_message = [](const std::function<void()>& f, const std::string& part) {
    try {
      f();
      ADD_FAILURE() << "expected InvalidInput mentioning " << part;
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  expect_message([&] { extractor.Extract(cv::Mat()); }, "empty");
  expect_message([&] { extractor.Extract(cv::Mat(100, 160, CV_8UC1, cv::Scalar(0))); }, "camera is 160x120");
  expect_message([&] { extractor.Extract(cv::Mat(120, 160, CV_8UC3, cv::Scalar(0))); }, "CV_8UC1");
  const cv::Mat image = TexturedImage(160, 120, 1);
  expect_message([&] { extractor.Extract(image, cv::Mat(120, 100, CV_8UC1, cv::Scalar(0))); }, "dynamic_mask");
  expect_message([&] { extractor.Extract(image, cv::Mat(), cv::Mat(120, 160, CV_8UC1, cv::Scalar(0))); },
                 "static_weight");
}

TEST(OrbExtractor, BlackAndTinyImagesGiveNoFeaturesWithoutCrashing) {
  OrbExtractor extractor(OrbExtractorOptions(), PlainCamera(640, 480));
  EXPECT_EQ(extractor.Extract(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0))).size(), 0u);
  OrbExtractor tiny(OrbExtractorOptions(), PlainCamera(20, 16));
  const OrbFeatures f = tiny.Extract(TexturedImage(20, 16, 3));
  EXPECT_EQ(f.size(), 0u);  // smaller than the border the descriptor needs
  EXPECT_EQ(f.descriptors.rows, 0);
}

TEST(OrbExtractor, DeterministicAndIndependentOfThreads) {
  const Camera camera = PlainCamera(320, 240);
  const cv::Mat image = TexturedImage(320, 240, 5);
  OrbExtractorOptions options;
  options.parallel_levels = true;  // levels on OpenCV's worker threads
  OrbExtractor extractor(options, camera);
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const OrbFeatures a = extractor.Extract(image);
  cv::setNumThreads(std::max(2, threads));
  const OrbFeatures b = extractor.Extract(image);
  cv::setNumThreads(threads);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 100u);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.keypoints[i].pt, b.keypoints[i].pt);
    EXPECT_EQ(a.keypoints[i].angle, b.keypoints[i].angle);
  }
  EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_HAMMING), 0.0);
}

// A rotated copy of an image gives the same descriptors at corresponding
// keypoints (rotation invariance of the orientation + rotated pattern).
TEST(OrbExtractor, DescriptorsAreRotationInvariant) {
  const Camera camera = PlainCamera(400, 400);
  cv::Mat image = TexturedImage(400, 400, 9);
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.5);
  cv::Mat rotated;
  cv::rotate(image, rotated, cv::ROTATE_90_CLOCKWISE);
  OrbExtractorOptions options;
  options.num_levels = 1;
  options.num_features = 300;
  OrbExtractor extractor(options, camera);
  const OrbFeatures a = extractor.Extract(image);
  const OrbFeatures b = extractor.Extract(rotated);
  const std::vector<Descriptor> da = DescriptorsFromMat(a.descriptors), db = DescriptorsFromMat(b.descriptors);
  int pairs = 0, good = 0;
  double angle_error = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    // (x, y) -> (H - 1 - y, x) under a clockwise quarter turn.
    const cv::Point2f expected(399.0f - a.keypoints[i].pt.y, a.keypoints[i].pt.x);
    for (size_t j = 0; j < b.size(); ++j) {
      if (cv::norm(b.keypoints[j].pt - expected) > 0.5) continue;
      ++pairs;
      good += HammingDistance(da[i], db[j]) <= 40;
      float d = std::fmod(b.keypoints[j].angle - a.keypoints[i].angle - 90.0f + 720.0f, 360.0f);
      angle_error += std::min(d, 360.0f - d);
    }
  }
  ASSERT_GT(pairs, 50);
  EXPECT_GT(good, 0.8 * pairs) << good << " of " << pairs << " rotated pairs within 40 bits";
  EXPECT_LT(angle_error / pairs, 3.0) << "mean orientation error [deg]";
}

TEST(OrbExtractor, UndistortsKeypointsWithTheCameraModel) {
  Camera camera = PlainCamera(640, 480);
  camera.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  OrbExtractor extractor(OrbExtractorOptions(), camera);
  const OrbFeatures f = extractor.Extract(TexturedImage(640, 480, 11));
  ASSERT_GT(f.size(), 500u);
  double worst = 0.0, moved = 0.0;
  for (size_t i = 0; i < f.size(); ++i) {
    const Eigen::Vector2d expected = camera.Undistort(Eigen::Vector2d(f.keypoints[i].pt.x, f.keypoints[i].pt.y));
    worst = std::max(worst, (expected - Eigen::Vector2d(f.points[i].x, f.points[i].y)).norm());
    moved = std::max(moved, static_cast<double>(cv::norm(f.points[i] - f.keypoints[i].pt)));
  }
  EXPECT_LT(worst, 0.01) << "px between cv::undistortPoints and Camera::Undistort";
  EXPECT_GT(moved, 2.0) << "distortion should move corner keypoints";
}

TEST(OrbExtractor, SpreadsAboutTheTargetCountOverATumFrame) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  OrbExtractor extractor(OrbExtractorOptions(), dataset->camera());
  OrbExtractionStats stats;
  const OrbFeatures f = extractor.Extract(Gray(dataset->Load(0)), cv::Mat(), cv::Mat(), &stats);
  std::printf("features on frame 0: %zu (per level:", f.size());
  for (int n : stats.features_per_level) std::printf(" %d", n);
  std::printf(")\n");
  EXPECT_GE(f.size(), 800u);
  EXPECT_LE(f.size(), 1000u);
  EXPECT_EQ(f.descriptors.rows, static_cast<int>(f.size()));
  ASSERT_EQ(stats.features_per_level.size(), 8u);
  for (int l = 0; l < 8; ++l) EXPECT_GT(stats.features_per_level[l], 0) << "level " << l;
  // Spread: at least 60% of the 8x6 image cells hold a feature.
  std::vector<int> cells(48, 0);
  for (const cv::KeyPoint& kp : f.keypoints)
    ++cells[std::min(5, static_cast<int>(kp.pt.y / 80)) * 8 + std::min(7, static_cast<int>(kp.pt.x / 80))];
  EXPECT_GE(std::count_if(cells.begin(), cells.end(), [](int c) { return c > 0; }), 29);
  for (float w : f.weights) EXPECT_EQ(w, 1.0f);
}

// Correspondences given by depth and the ground-truth motion between two
// frames mostly have close descriptors.
TEST(OrbExtractor, TrueCorrespondencesHaveCloseDescriptors) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  const Camera& camera = dataset->camera();
  const Frame f0 = dataset->Load(20), f1 = dataset->Load(22);
  OrbExtractor extractor(OrbExtractorOptions(), camera);
  const OrbFeatures a = extractor.Extract(Gray(f0));
  const OrbFeatures b = extractor.Extract(Gray(f1));
  const std::vector<Descriptor> da = DescriptorsFromMat(a.descriptors), db = DescriptorsFromMat(b.descriptors);
  const Rigid3d cam1_from_cam0 = f1.world_from_cam_gt->Inverse() * *f0.world_from_cam_gt;
  std::vector<int> true_distances, random_distances;
  for (size_t i = 0; i < a.size(); ++i) {
    const cv::KeyPoint& kp = a.keypoints[i];
    const float z = f0.depth.at(cvRound(kp.pt.x), cvRound(kp.pt.y));
    if (!(z > 0.0f)) continue;
    const Eigen::Vector3d p1 = cam1_from_cam0 * camera.Unproject(Eigen::Vector2d(a.points[i].x, a.points[i].y), z);
    const Eigen::Vector2d uv = camera.Project(p1);
    int best = -1;
    double best_d = 2.0 * std::pow(1.2, kp.octave);
    for (size_t j = 0; j < b.size(); ++j) {
      if (std::abs(b.keypoints[j].octave - kp.octave) > 0) continue;
      const double d = (Eigen::Vector2d(b.points[j].x, b.points[j].y) - uv).norm();
      if (d < best_d) {
        best_d = d;
        best = static_cast<int>(j);
      }
    }
    if (best < 0) continue;
    true_distances.push_back(HammingDistance(da[i], db[best]));
    random_distances.push_back(HammingDistance(da[i], db[(i * 7919) % b.size()]));
  }
  ASSERT_GT(true_distances.size(), 100u);
  std::sort(true_distances.begin(), true_distances.end());
  std::sort(random_distances.begin(), random_distances.end());
  const int median_true = true_distances[true_distances.size() / 2];
  const int median_random = random_distances[random_distances.size() / 2];
  std::printf("descriptor distance of %zu true correspondences: median %d, 80%% %d; random pairs: median %d, 10%% %d\n",
              true_distances.size(), median_true, true_distances[true_distances.size() * 8 / 10], median_random,
              random_distances[random_distances.size() / 10]);
  // Our Gaussian test pattern is not decorrelated like ORB's learned one, so
  // unrelated descriptors differ in about 75 of 256 bits rather than 128.
  EXPECT_LT(median_true, 25);
  EXPECT_GT(median_random, 60);
  EXPECT_LT(true_distances[true_distances.size() * 8 / 10], random_distances[random_distances.size() / 10]);
}

// Masks removing 40% of the image (a band on the left, the right, in the
// middle, or blocks like people) on real TUM frames: with the adaptive
// threshold the feature count stays within 20% of the unmasked count; with
// the fixed threshold it drops by more than 20%.
TEST(OrbExtractor, AdaptiveThresholdKeepsTheCountWhenFortyPercentIsMasked) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  const int w = dataset->camera().width, h = dataset->camera().height;
  std::vector<std::pair<std::string, cv::Mat>> masks;
  auto add = [&](const std::string& name, const std::vector<cv::Rect>& rects) {
    cv::Mat m(h, w, CV_8UC1, cv::Scalar(0));
    for (const cv::Rect& r : rects) m(r).setTo(255);
    masks.emplace_back(name, m);
  };
  const int band = static_cast<int>(0.4 * w);
  add("left 40%", {cv::Rect(0, 0, band, h)});
  add("right 40%", {cv::Rect(w - band, 0, band, h)});
  add("middle 40%", {cv::Rect((w - band) / 2, 0, band, h)});
  // Two "people": 2 x (128 x 480) = 40% of the image.
  add("two blocks", {cv::Rect(100, 0, 128, h), cv::Rect(420, 0, 128, h)});

  OrbExtractorOptions adaptive_options;
  adaptive_options.mask_dilation = 0;  // mask exactly 40%
  OrbExtractorOptions fixed_options = adaptive_options;
  fixed_options.adaptive_threshold = false;
  OrbExtractor adaptive(adaptive_options, dataset->camera());
  OrbExtractor fixed(fixed_options, dataset->camera());
  for (size_t index : {0, 60, 120, 180, 240}) {
    const cv::Mat gray = Gray(dataset->Load(index));
    const double adaptive_full = static_cast<double>(adaptive.Extract(gray).size());
    const double fixed_full = static_cast<double>(fixed.Extract(gray).size());
    for (const auto& [name, mask] : masks) {
      EXPECT_NEAR(cv::countNonZero(mask) / static_cast<double>(w * h), 0.4, 0.01);
      OrbExtractionStats stats;
      const OrbFeatures a = adaptive.Extract(gray, mask, cv::Mat(), &stats);
      const OrbFeatures f = fixed.Extract(gray, mask);
      const double ratio_adaptive = a.size() / adaptive_full, ratio_fixed = f.size() / fixed_full;
      std::printf("frame %3zu, mask %-10s: adaptive %4zu / %4.0f = %.2f (threshold down to %d), fixed %4zu / %4.0f = %.2f\n",
                  index, name.c_str(), a.size(), adaptive_full, ratio_adaptive, stats.min_threshold_used, f.size(),
                  fixed_full, ratio_fixed);
      EXPECT_GE(ratio_adaptive, 0.8) << "frame " << index << ", mask " << name;
      EXPECT_LE(ratio_adaptive, 1.2) << "frame " << index << ", mask " << name;
      EXPECT_LT(ratio_fixed, 0.8) << "frame " << index << ", mask " << name;
      for (const OrbFeatures* features : {&a, &f})
        for (const cv::KeyPoint& kp : features->keypoints)
          ASSERT_EQ(mask.at<uint8_t>(cvRound(kp.pt.y), cvRound(kp.pt.x)), 0) << "feature inside the mask";
    }
  }
}

TEST(OrbExtractor, NoFeatureInsideTheDilatedMaskAndSoftWeights) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  const int w = dataset->camera().width, h = dataset->camera().height;
  OrbExtractorOptions options;
  options.mask_dilation = 4;
  OrbExtractor extractor(options, dataset->camera());
  cv::Mat mask(h, w, CV_8UC1, cv::Scalar(0));
  cv::circle(mask, cv::Point(320, 240), 120, cv::Scalar(255), cv::FILLED);
  // Soft weights: 1 on the left half, 0.25 on the right half.
  cv::Mat weight(h, w, CV_32FC1, cv::Scalar(1.0f));
  weight(cv::Rect(w / 2, 0, w - w / 2, h)).setTo(0.25f);
  weight.at<float>(10, 10) = std::numeric_limits<float>::quiet_NaN();
  const OrbFeatures f = extractor.Extract(Gray(dataset->Load(30)), mask, weight);
  ASSERT_GT(f.size(), 500u);
  for (size_t i = 0; i < f.size(); ++i) {
    const cv::Point2f p = f.keypoints[i].pt;
    EXPECT_GT(cv::norm(p - cv::Point2f(320, 240)), 120 + 4 - 1.5) << "feature at " << p << " is in the dilated mask";
    EXPECT_FLOAT_EQ(f.weights[i], cvRound(p.x) >= w / 2 ? 0.25f : 1.0f);
  }
}

// Where corners are scarce (the TUM frames at half contrast), re-spreading
// the budget is not enough: the threshold relaxation (alpha = 1) keeps the
// count within 20%, no relaxation (alpha = 0) does not.
TEST(OrbExtractor, ThresholdRelaxationMattersWhereCornersAreScarce) {
  DYPHO_REQUIRE_SHARED_DATA(kRpy);
  const auto dataset = OpenDataset(SharedData(kRpy));
  const int w = dataset->camera().width, h = dataset->camera().height;
  cv::Mat mask(h, w, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(0, 0, static_cast<int>(0.4 * w), h)).setTo(255);
  std::vector<cv::Mat> frames;
  for (size_t index : {0, 120, 240}) {
    cv::Mat gray = Gray(dataset->Load(index));
    gray.convertTo(gray, CV_8U, 0.5, 64.0);  // half contrast around mid-grey
    frames.push_back(gray);
  }
  auto ratio = [&](double alpha) {
    OrbExtractorOptions o;
    o.mask_dilation = 0;
    o.adaptive_exponent = alpha;
    OrbExtractor extractor(o, dataset->camera());
    double full = 0.0, masked = 0.0;
    for (const cv::Mat& gray : frames) {
      full += static_cast<double>(extractor.Extract(gray).size());
      masked += static_cast<double>(extractor.Extract(gray, mask).size());
    }
    std::printf("half contrast, alpha %.1f: %.0f features unmasked, %.0f with 40%% masked (ratio %.2f)\n", alpha,
                full / frames.size(), masked / frames.size(), masked / full);
    return masked / full;
  };
  EXPECT_GE(ratio(1.0), 0.8);
  EXPECT_LT(ratio(0.0), 0.8);
}

}  // namespace
}  // namespace dypho
