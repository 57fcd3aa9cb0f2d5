// A fundamental matrix by RANSAC over 7-point samples, in fixed-size
// arithmetic: the model, the error and the stopping rule of OpenCV's
// findFundamentalMat(FM_RANSAC) (OpenCV 4.6 calib3d/src/fundam.cpp and
// ptsetreg.cpp: a 7-point sample gives up to 3 solutions of
// det(a F1 + (1 - a) F2) = 0; a match is an inlier when the larger of its
// two squared point-to-epipolar-line distances is at most threshold^2; the
// number of samples shrinks to log(1 - confidence) / log(1 - w^7) with the
// best inlier ratio w so far), at a fraction of its cost per sample: the
// null space of the 7x9 system by a fixed-size LU instead of a general SVD,
// the cubic in closed form, and no allocation per sample. The samples are
// drawn from a fixed seed, so a call is deterministic, but they are not
// OpenCV's: the two pick different (equally good) models. Unlike OpenCV's,
// the best sample's model is then refitted to its inliers by least squares
// (up to `refits` times, while the inliers do not drop).
//
// Hartley's normalisation (Hartley & Zisserman, Multiple View Geometry,
// 2nd ed., 11.2) conditions the 7-point system; models are scored in pixels.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace dypho {

struct FundamentalFit {
  bool ok = false;              // a model with at least 7 inliers was found
  cv::Matx33d F;                // x2^T F x1 = 0 for matches (x1 in image 1, x2 in image 2) [px]
  std::vector<uint8_t> inlier;  // 1 = inlier of F, per match
  int inliers = 0;
  int samples = 0;              // 7-point samples drawn
};

// p1[i] in image 1 matches p2[i] in image 2 (at least 7 matches, else
// ok = false). threshold_px > 0, 0 < confidence < 1, max_samples >= 1.
FundamentalFit FitFundamentalRansac(const std::vector<cv::Point2f>& p1, const std::vector<cv::Point2f>& p2,
                                    double threshold_px, double confidence, int max_samples = 1000,
                                    int refits = 2, uint64_t seed = 0x9E3779B97F4A7C15ull);

// The real roots of c3 a^3 + c2 a^2 + c1 a + c0 = 0 (1 to 3 of them; a
// quadratic or linear equation when the leading coefficients vanish).
// Exposed for the test.
int RealCubicRoots(double c3, double c2, double c1, double c0, double roots[3]);

}  // namespace dypho
