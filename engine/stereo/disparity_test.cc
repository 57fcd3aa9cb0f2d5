// Dense disparity: exact answers on synthetic pairs, accuracy on Middlebury.
#include "engine/stereo/disparity.h"

#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/stereo/dense_match.h"
#include "engine/stereo/descriptor.h"
#include "engine/stereo/support_points.h"
#include "engine/stereo/triangulation.h"
#include "tests/test_data.h"

namespace dypho::stereo {
namespace {

// A textured image (smoothed uniform noise), fixed seed.
cv::Mat Texture(int w, int h, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat noise(h, w, CV_8U);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(noise, noise, cv::Size(3, 3), 0.8);
  return noise;
}

// Right image of a scene: background plane at disparity d_bg, a square at d_fg.
// right(x) = left(x + d): every left pixel is seen in the right one at x - d.
struct SyntheticPair {
  cv::Mat left, right, truth;  // truth: CV_32F disparity of the left image
};

SyntheticPair MakePair(int w, int h, int d_bg, int d_fg, cv::Rect square) {
  const cv::Mat background = Texture(w + 64, h, 1), foreground = Texture(w + 64, h, 2);
  SyntheticPair pair;
  pair.left.create(h, w, CV_8U), pair.right.create(h, w, CV_8U);
  pair.truth.create(h, w, CV_32F);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool fg = square.contains(cv::Point(x, y));
      pair.left.at<uint8_t>(y, x) = fg ? foreground.at<uint8_t>(y, x + 32) : background.at<uint8_t>(y, x + 32);
      pair.truth.at<float>(y, x) = float(fg ? d_fg : d_bg);
      // The right pixel at x sees the left pixel x + d of whichever surface is in front.
      const bool fg_r = square.contains(cv::Point(x + d_fg, y));
      pair.right.at<uint8_t>(y, x) = fg_r ? foreground.at<uint8_t>(y, x + d_fg + 32)
                                          : background.at<uint8_t>(y, x + d_bg + 32);
    }
  return pair;
}

// Fraction of pixels of `region` whose estimate is within tol of truth (missing = wrong).
double FractionCorrect(const DisparityResult& r, const cv::Mat& truth, cv::Rect region, float tol) {
  int good = 0, total = 0;
  for (int y = region.y; y < region.y + region.height; ++y)
    for (int x = region.x; x < region.x + region.width; ++x, ++total)
      if (r.valid.at<uint8_t>(y, x) && std::abs(r.disparity.at<float>(y, x) - truth.at<float>(y, x)) <= tol)
        ++good;
  return double(good) / total;
}

TEST(StereoDisparity, ElasRecoversAFrontoParallelPlaneExactly) {
  const SyntheticPair pair = MakePair(320, 240, 12, 12, cv::Rect());
  DisparityOptions options;
  options.SetMaxDisparity(64);
  const DisparityResult r = ComputeDisparity(pair.left, pair.right, options);
  // Columns x >= 12 have a match; within a quarter pixel everywhere (sub-pixel on).
  const double correct = FractionCorrect(r, pair.truth, cv::Rect(12, 0, 308, 240), 0.25f);
  std::printf("plane: %.4f of pixels within 0.25 px\n", correct);
  EXPECT_GT(correct, 0.999);
  // The 12 left columns have no match: border extrapolation fills them with 12.
  EXPECT_GT(FractionCorrect(r, pair.truth, cv::Rect(0, 0, 12, 240), 0.25f), 0.99);
}

TEST(StereoDisparity, ElasKeepsADepthDiscontinuity) {
  const cv::Rect square(100, 60, 120, 120);
  const SyntheticPair pair = MakePair(320, 240, 8, 30, square);
  DisparityOptions options;
  options.SetMaxDisparity(64);
  const DisparityResult r = ComputeDisparity(pair.left, pair.right, options);
  // Inside the square (2 px from its edges) and the background away from the occlusion.
  const double inside = FractionCorrect(r, pair.truth, cv::Rect(102, 62, 116, 116), 0.5f);
  const double outside = FractionCorrect(r, pair.truth, cv::Rect(240, 0, 80, 240), 0.5f);
  std::printf("square: %.4f inside, %.4f background\n", inside, outside);
  EXPECT_GT(inside, 0.999);
  EXPECT_GT(outside, 0.999);
  // The occluded strip left of the square (background seen only in the left image)
  // is filled with the background disparity, not the square's.
  const double occluded = FractionCorrect(r, pair.truth, cv::Rect(100 - 20, 70, 18, 100), 1.0f);
  std::printf("occluded strip: %.4f background\n", occluded);
  EXPECT_GT(occluded, 0.9);
}

TEST(StereoDisparity, DepthAndKittiEncodingAreExact) {
  cv::Mat disparity = (cv::Mat_<float>(1, 4) << 0.f, 10.f, 2.5f, 40.f);
  cv::Mat valid = (cv::Mat_<uint8_t>(1, 4) << 255, 255, 255, 0);
  const cv::Mat depth = DisparityToDepth(disparity, valid, 700.0, 0.5);
  EXPECT_FLOAT_EQ(depth.at<float>(0, 0), 0.f);    // d = 0: no depth
  EXPECT_FLOAT_EQ(depth.at<float>(0, 1), 35.f);   // 700 * 0.5 / 10
  EXPECT_FLOAT_EQ(depth.at<float>(0, 2), 140.f);  // 700 * 0.5 / 2.5
  EXPECT_FLOAT_EQ(depth.at<float>(0, 3), 0.f);    // invalid
  const cv::Mat kitti = DisparityToKitti16(disparity, valid);
  EXPECT_EQ(kitti.type(), CV_16U);
  EXPECT_EQ(kitti.at<uint16_t>(0, 1), 2560);
  EXPECT_EQ(kitti.at<uint16_t>(0, 2), 640);
  EXPECT_EQ(kitti.at<uint16_t>(0, 3), 0);
  EXPECT_EQ(kitti.at<uint16_t>(0, 0), 1);  // a valid zero disparity stays distinguishable from "none"
  EXPECT_THROW(DisparityToDepth(disparity, valid, 700.0, 0.0), InvalidInput);
}

TEST(StereoDisparity, BadInputIsAClearError) {
  const cv::Mat a(40, 60, CV_8U, cv::Scalar(0)), b(40, 61, CV_8U, cv::Scalar(0));
  DisparityOptions options;
  try {
    ComputeDisparity(a, b, options);
    FAIL() << "size mismatch accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("differ in size: left 60x40, right 61x40"), std::string::npos);
  }
  EXPECT_THROW(ComputeDisparity(cv::Mat(), a, options), InvalidInput);
  EXPECT_THROW(ParseDisparityMethod("bm"), InvalidInput);
  options.elas.max_disparity = 300;
  try {
    ComputeDisparity(a, a, options);
    FAIL() << "max_disparity 300 accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("elas.max_disparity"), std::string::npos);
  }
}

// Bad-2px fraction over ground-truth pixels, missing estimates counted as errors.
struct Score {
  double bad2 = 0, density = 0, bad2_estimated = 0;
};

Score Evaluate(const DisparityResult& r, const cv::Mat& gt_png, double gt_scale) {
  int total = 0, bad = 0, estimated = 0, bad_estimated = 0;
  for (int y = 0; y < gt_png.rows; ++y)
    for (int x = 0; x < gt_png.cols; ++x) {
      const int g = gt_png.at<uint8_t>(y, x);
      if (g == 0) continue;
      ++total;
      if (!r.valid.at<uint8_t>(y, x)) { ++bad; continue; }
      ++estimated;
      if (std::abs(r.disparity.at<float>(y, x) - g / gt_scale) > 2.0) ++bad, ++bad_estimated;
    }
  return {double(bad) / total, double(estimated) / total, double(bad_estimated) / std::max(1, estimated)};
}

void CheckMiddlebury(const std::string& folder, const std::string& left, const std::string& right,
                     const std::string& gt, double scale, int max_disparity) {
  const std::string dir = testing::SharedData("middlebury/" + folder + "/");
  const cv::Mat l = cv::imread(dir + left, cv::IMREAD_COLOR), r = cv::imread(dir + right, cv::IMREAD_COLOR);
  const cv::Mat truth = cv::imread(dir + gt, cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(l.empty() || r.empty() || truth.empty());
  DisparityOptions options;
  options.SetMaxDisparity(max_disparity);
  const Score elas = Evaluate(ComputeDisparity(l, r, options), truth, scale);
  options.method = DisparityMethod::kSgbm;
  const Score sgbm = Evaluate(ComputeDisparity(l, r, options), truth, scale);
  std::printf("%s: elas bad2 %.4f (dense %.4f, %.4f of estimated), sgbm bad2 %.4f (dense %.4f, %.4f)\n",
              folder.c_str(), elas.bad2, elas.density, elas.bad2_estimated, sgbm.bad2, sgbm.density,
              sgbm.bad2_estimated);
  // Target of issue 18: at most half of SGBM's error (measured 0.37x on cones, 0.20x on cloth3).
  EXPECT_LT(elas.bad2, 0.5 * sgbm.bad2);
  EXPECT_GT(elas.density, 0.95);
}

TEST(StereoDisparity, MiddleburyConesHalvesSgbmError) {
  DYPHO_REQUIRE_SHARED_DATA("middlebury/cones");
  CheckMiddlebury("cones", "im2.png", "im6.png", "disp2.png", 4.0, 64);
}

TEST(StereoDisparity, MiddleburyCloth3HalvesSgbmError) {
  DYPHO_REQUIRE_SHARED_DATA("middlebury/cloth3");
  CheckMiddlebury("cloth3", "view1.png", "view5.png", "disp1.png", 2.0, 128);
}

// The vectorised dense stage gives exactly the reference's disparities and
// confidences, for both reference images, on a real KITTI pair, with the
// default options and with ones that take its other paths (a prior table not
// flat beyond 15 px, a wide plane neighbourhood, a nonzero minimum disparity).
TEST(StereoDisparity, VectorisedDenseMatchEqualsTheReference) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51/image_0/000010.png");
  const std::string dir = testing::SharedData("kitti_stereo_51/");
  const cv::Mat l = cv::imread(dir + "image_0/000010.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat r = cv::imread(dir + "image_1/000010.png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(l.empty() || r.empty());
  if (!MatchDenseIsVectorised()) GTEST_SKIP() << "built without AVX2: MatchDense is the reference";
  const cv::Mat desc_l = ComputeDescriptors(l), desc_r = ComputeDescriptors(r);
  const cv::Mat tex_l = DescriptorTexture(desc_l), tex_r = DescriptorTexture(desc_r);
  ElasOptions wide;
  wide.sigma = 8.f, wide.plane_radius = 9, wide.min_disparity = 3, wide.beta = 0.05f;
  for (const ElasOptions& o : {ElasOptions(), wide}) {
    const std::vector<SupportPoint> points = ComputeSupportPoints(desc_l, desc_r, tex_l, o);
    ASSERT_GT(points.size(), 1000u);
    for (const bool right : {false, true}) {
      const cv::Mat prior = PlanePrior(points, l.size(), right);
      const cv::Mat &ref = right ? desc_r : desc_l, &other = right ? desc_l : desc_r, &tex = right ? tex_r : tex_l;
      const DenseMatch fast = MatchDense(ref, other, tex, prior, points, right, o);
      const DenseMatch slow = MatchDenseReference(ref, other, tex, prior, points, right, o);
      EXPECT_EQ(cv::countNonZero(fast.disparity != slow.disparity), 0) << "right " << right << " sigma " << o.sigma;
      EXPECT_EQ(cv::countNonZero(fast.confidence != slow.confidence), 0) << "right " << right << " sigma " << o.sigma;
      // Most pixels get an estimate (the comparison is not over empty images).
      EXPECT_GT(cv::countNonZero(slow.disparity >= 0), l.total() * 3 / 4);
    }
  }
}

}  // namespace
}  // namespace dypho::stereo
