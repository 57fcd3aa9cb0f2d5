// Motion-consistency check of tracked features against the epipolar geometry
// (the "non-prior dynamic features" of the nearshore USV SLAM of Zhang et al.,
// J. Mar. Sci. Eng. 2025, which follows DS-SLAM's moving consistency check):
//  1. features of the previous frame (given, e.g. the tracker's, or FAST
//     corners spread over a grid) are tracked into the current frame by
//     pyramidal Lucas-Kanade (cv::calcOpticalFlowPyrLK);
//  2. matches within border_px of the image border, or whose
//     (2 patch_radius + 1)^2 patches differ by more than
//     max_patch_difference on average, are discarded;
//  3. the fundamental matrix F is fitted by RANSAC (cv::findFundamentalMat;
//     EpipolarOptions::method)
//     to the remaining matches outside an optional exclusion mask (e.g. the
//     raw dynamic mask), falling back to all of them when too few remain;
//     the RANSAC inlier threshold is kept tight (0.3 px): between consecutive
//     frames the baseline is small (about 1-5 cm) against depths of metres,
//     F is then weakly constrained, and with a 1 px threshold RANSAC often
//     settles on an F that also explains a moving object (measured on the
//     synthetic room: with 2-6 cm of baseline a 1 px threshold flags 15% of
//     a card moving 9 px across the epipolar lines, 0.3 px flags all of it);
//  4. every remaining feature whose distance to its epipolar line,
//        d = |p2^T F p1| / sqrt(A^2 + B^2),  (A, B, C) = F p1,
//     exceeds epipolar_threshold_px is dynamic.
// Points are undistorted with the camera's distortion before 3 and 4.
// Limitation: with (almost) no camera translation F is not defined by the
// static scene and the check says nothing reliable.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera.h"

namespace dypho {

struct EpipolarOptions {
  int max_features = 300;              // FAST corners detected in the previous frame when none are given, >= 8
  int fast_threshold = 20;             // FAST threshold for that detection [intensity levels], 1..255
  int grid_cell_px = 40;               // detected corners are spread over cells of this size [px], >= 8
  int lk_window_px = 15;               // Lucas-Kanade window edge [px], odd, 5..61
  int lk_levels = 3;                   // pyramid levels above the full image, 0..6
  int border_px = 10;                  // matches nearer the image border are discarded [px], >= 0
  int patch_radius_px = 1;             // compared patches are (2r+1)^2 (3x3 as in DS-SLAM) [px], 0..7
  double max_patch_difference = 30.0;  // larger mean absolute patch difference: discarded [intensity levels], > 0
  // Robust fit of F: fast_ransac (our own 7-point RANSAC,
  // masking/fundamental_ransac.h: OpenCV's FM_RANSAC model, error and
  // stopping rule in fixed-size arithmetic, then a least-squares refit on
  // the inliers; 1.0 ms a pair against 4.8-6.4 ms for ransac on fr1 LK
  // matches, 4-5 % more inliers; the ATE differences between these methods
  // are within the spread between two RANSAC draws: BENCHMARKS, issue 20),
  // ransac (cv::FM_RANSAC),
  // usac_accurate (cv::USAC_ACCURATE, LO-RANSAC with graph-cut local
  // optimisation), usac_fast (cv::USAC_FAST), lmeds, magsac (cv::USAC_MAGSAC).
  std::string method = "fast_ransac";
  double ransac_threshold_px = 0.3;    // RANSAC inlier distance for F [px], > 0 (see 3. above)
  double ransac_confidence = 0.999;    // RANSAC confidence, (0, 1)
  double epipolar_threshold_px = 1.0;  // farther from the epipolar line: dynamic [px], > 0
  int min_fit_points = 15;             // fewer matches outside the exclusion mask: fit F to all, >= 8

  bool IsValid(std::string* error) const;
};

struct EpipolarResult {
  std::vector<cv::Point2f> prev_points;            // features in the previous frame [px, as given/detected]
  std::vector<cv::Point2f> points;                 // their tracked positions in the current frame [px]
  std::vector<uint8_t> valid;                      // 1 = tracked and passed the border and patch checks
  std::vector<uint8_t> dynamic;                    // 1 = valid and farther than the threshold from its epipolar line
  std::vector<float> distance;                     // epipolar distance [px] (valid features; -1 otherwise)
  cv::Matx33d fundamental = cv::Matx33d::zeros();  // x_cur^T F x_prev = 0 (undistorted pixels)
  bool has_fundamental = false;                    // false: too few matches or RANSAC failed (nothing flagged)
  int fit_points = 0;                              // matches F was fitted to
  int fit_inliers = 0;                             // RANSAC inliers among them
};

class EpipolarChecker {
 public:
  // Throws InvalidInput naming the field for invalid options or camera.
  EpipolarChecker(const EpipolarOptions& options, const Camera& camera);

  // `prev_gray`, `gray`: CV_8UC1 of the camera's size. `prev_points`: the
  // features to check (empty = detect FAST corners). `exclude`: optional
  // CV_8UC1 of the camera's size in the current frame; matches landing on a
  // nonzero pixel are not used to fit F (they are still checked).
  EpipolarResult Check(const cv::Mat& prev_gray, const cv::Mat& gray, const std::vector<cv::Point2f>& prev_points = {},
                       const cv::Mat& exclude = cv::Mat()) const;

  // FAST corners spread over the grid (the detection used when no points are given).
  std::vector<cv::Point2f> DetectFeatures(const cv::Mat& gray) const;

  const EpipolarOptions& options() const { return options_; }

 private:
  EpipolarOptions options_;
  Camera camera_;
};

// Distance [px] of p2 from the epipolar line F p1.
double EpipolarDistance(const cv::Matx33d& fundamental, const cv::Point2d& p1, const cv::Point2d& p2);

}  // namespace dypho
