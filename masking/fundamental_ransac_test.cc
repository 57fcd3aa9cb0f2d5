// Our 7-point RANSAC for F (masking/fundamental_ransac.h): the cubic's
// roots exactly, the true F recovered from a synthetic two-view scene with
// noise and outliers (against OpenCV's FM_RANSAC on the same matches),
// determinism, and degenerate input.
#include "masking/fundamental_ransac.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include <opencv2/calib3d.hpp>

namespace dypho {
namespace {

double LineDistance(const cv::Matx33d& f, const cv::Point2f& a, const cv::Point2f& b) {
  const cv::Vec3d l = f * cv::Vec3d(a.x, a.y, 1.0);
  return std::abs(l[0] * b.x + l[1] * b.y + l[2]) / std::hypot(l[0], l[1]);
}

TEST(FundamentalRansac, CubicRoots) {
  double r[3];
  // (a - 1)(a - 2)(a + 3) = a^3 - 7a + 6
  ASSERT_EQ(RealCubicRoots(1, 0, -7, 6, r), 3);
  std::sort(r, r + 3);
  EXPECT_NEAR(r[0], -3, 1e-12);
  EXPECT_NEAR(r[1], 1, 1e-12);
  EXPECT_NEAR(r[2], 2, 1e-12);
  // 2(a - 0.5)(a^2 + 1): one real root.
  ASSERT_EQ(RealCubicRoots(2, -1, 2, -1, r), 1);
  EXPECT_NEAR(r[0], 0.5, 1e-12);
  // No cubic term: (a - 4)(a + 1) = a^2 - 3a - 4.
  ASSERT_EQ(RealCubicRoots(0, 1, -3, -4, r), 2);
  std::sort(r, r + 2);
  EXPECT_NEAR(r[0], -1, 1e-12);
  EXPECT_NEAR(r[1], 4, 1e-12);
  EXPECT_EQ(RealCubicRoots(0, 0, 0, 0, r), 0);
}

struct TwoViews {
  std::vector<cv::Point2f> p1, p2;
  std::vector<bool> outlier;
  cv::Matx33d true_f;
};

// Points 2-6 m in front of a 640x480 camera that turns 3 degrees and moves
// 5 cm; `noise_px` Gaussian noise on the second view; `outliers` of the
// matches moved by 3-20 px.
TwoViews MakeTwoViews(int n, double outlier_fraction, double noise_px, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), depth(2, 6), shift(3, 20), unit(0, 1);
  std::normal_distribution<double> noise(0, noise_px);
  const cv::Matx33d k(525, 0, 319.5, 0, 525, 239.5, 0, 0, 1);
  cv::Matx33d r;
  cv::Rodrigues(cv::Vec3d(0.02, -0.045, 0.01), r);
  const cv::Vec3d t(0.05, -0.01, 0.02);
  const cv::Matx33d tx(0, -t[2], t[1], t[2], 0, -t[0], -t[1], t[0], 0);
  TwoViews v;
  v.true_f = k.inv().t() * tx * r * k.inv();
  while (static_cast<int>(v.p1.size()) < n) {
    const cv::Vec3d x1(u(rng) * 300 + 319.5, u(rng) * 220 + 239.5, 1.0);
    const cv::Vec3d xc = k.inv() * x1 * depth(rng);
    const cv::Vec3d x2 = k * (r * xc + t);
    cv::Point2f q(static_cast<float>(x2[0] / x2[2] + noise(rng)), static_cast<float>(x2[1] / x2[2] + noise(rng)));
    if (q.x < 0 || q.y < 0 || q.x > 639 || q.y > 479) continue;
    const bool out = unit(rng) < outlier_fraction;
    if (out) {
      const double a = unit(rng) * 2 * M_PI, s = shift(rng);
      q += cv::Point2f(static_cast<float>(s * std::cos(a)), static_cast<float>(s * std::sin(a)));
    }
    v.p1.emplace_back(static_cast<float>(x1[0]), static_cast<float>(x1[1]));
    v.p2.push_back(q);
    v.outlier.push_back(out);
  }
  return v;
}

TEST(FundamentalRansac, RecoversTheTrueEpipolarGeometryAmongOutliers) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const TwoViews v = MakeTwoViews(300, 0.3, 0.1, seed);
    const FundamentalFit fit = FitFundamentalRansac(v.p1, v.p2, 0.3, 0.999);
    ASSERT_TRUE(fit.ok) << seed;
    int true_in = 0, kept = 0, outliers_in = 0;
    double sum_true = 0;
    int n_true = 0;
    for (size_t i = 0; i < v.p1.size(); ++i) {
      if (v.outlier[i]) {
        outliers_in += fit.inlier[i];
        continue;
      }
      ++true_in;
      kept += fit.inlier[i];
      // The true matches lie on the fitted F's epipolar lines to the noise.
      sum_true += LineDistance(fit.F, v.p1[i], v.p2[i]);
      ++n_true;
    }
    EXPECT_EQ(fit.inliers, std::count(fit.inlier.begin(), fit.inlier.end(), 1));
    EXPECT_LT(sum_true / n_true, 0.15) << seed;
    EXPECT_GT(kept, 0.9 * true_in) << seed;  // 0.1 px noise: nearly all within 0.3 px
    // An outlier is kept only when its shift happens to run along its line.
    EXPECT_LT(outliers_in, 0.05 * (v.p1.size() - true_in)) << seed;
    // The whole image agrees with the true F: every outlier lies off the fitted lines by > 1 px
    // wherever it lies off the true lines by > 2 px.
    for (size_t i = 0; i < v.p1.size(); ++i)
      if (LineDistance(v.true_f, v.p1[i], v.p2[i]) > 2.0) EXPECT_GT(LineDistance(fit.F, v.p1[i], v.p2[i]), 1.0);
    // At least as many inliers as OpenCV's RANSAC on the same matches (to a few).
    std::vector<uint8_t> cv_mask;
    const cv::Mat cv_f = cv::findFundamentalMat(v.p1, v.p2, cv::FM_RANSAC, 0.3, 0.999, cv_mask);
    ASSERT_EQ(cv_f.rows, 3);
    EXPECT_GE(fit.inliers, cv::countNonZero(cv_mask) - 3) << seed;
    // Deterministic.
    const FundamentalFit again = FitFundamentalRansac(v.p1, v.p2, 0.3, 0.999);
    EXPECT_EQ(again.inlier, fit.inlier);
    EXPECT_EQ(again.samples, fit.samples);
  }
}

TEST(FundamentalRansac, StopsEarlyOnCleanMatchesAndRespectsTheCap) {
  const TwoViews clean = MakeTwoViews(200, 0.0, 0.05, 7);
  const FundamentalFit fit = FitFundamentalRansac(clean.p1, clean.p2, 0.3, 0.999);
  ASSERT_TRUE(fit.ok);
  EXPECT_LT(fit.samples, 30);  // all inliers: log(0.001) / log(1 - 1) -> a few samples
  const TwoViews noisy = MakeTwoViews(200, 0.6, 0.1, 8);
  const FundamentalFit capped = FitFundamentalRansac(noisy.p1, noisy.p2, 0.3, 0.999, 50);
  EXPECT_LE(capped.samples, 50);
}

TEST(FundamentalRansac, TooFewOrDegenerateMatches) {
  std::vector<cv::Point2f> p(6, cv::Point2f(1, 2));
  EXPECT_FALSE(FitFundamentalRansac(p, p, 0.3, 0.999).ok);
  // Seven copies of one match: every sample is degenerate.
  std::vector<cv::Point2f> same(20, cv::Point2f(100, 50)), other(20, cv::Point2f(110, 52));
  const FundamentalFit fit = FitFundamentalRansac(same, other, 0.3, 0.999, 100);
  EXPECT_FALSE(fit.ok);
  // Sizes that differ.
  std::vector<cv::Point2f> a(10, cv::Point2f(1, 1)), b(9, cv::Point2f(1, 1));
  EXPECT_FALSE(FitFundamentalRansac(a, b, 0.3, 0.999).ok);
}

}  // namespace
}  // namespace dypho
