// Depth of the left image's ORB features from the right image of a rectified
// stereo pair, without a dense disparity (the sparse stereo matching of
// stereo ORB-SLAM: Mur-Artal and Tardós, "ORB-SLAM2", IEEE T-RO 2017, section
// III-A; the steps and thresholds below are ours).
//
// 1. ORB features of the right image (the tracker's extractor, no mask).
// 2. A right feature at row v and level l serves the rows within
//    row_band_px * scale_factor^l of v.
// 3. For each left feature (u, v, level l): the right features serving row v,
//    of level l-1..l+1, with u - max_disparity <= u_r <= u - min_disparity;
//    the one at the least Hamming distance, kept when it is at most
//    max_distance bits and below ratio x the second least (a repeated
//    structure along the row gives no depth).
// 4. Sub-pixel: the sum of absolute differences of a window_px x window_px
//    patch of the left grey image around (u, v) against the right one around
//    (u_r + s, v), s in [-search_px, search_px] (level-0 pixels); a parabola
//    through the best s and its neighbours; a best s at the end of the range
//    is rejected (the descriptor match was off).
// 5. d = u - u_r; depth = fx * baseline / d for min_disparity <= d; the
//    matches whose SAD exceeds outlier_factor x the median SAD are dropped.
//
// With a coarse depth prior (StereoFeatureDepthsFromPrior, for example the
// frame loader's half-resolution dense disparity) steps 1-3 are replaced: the
// prior's disparities in the 3x3 neighbourhood of the feature's prior pixel
// give a range [d_lo - prior_search_px, d_hi + prior_search_px]; step 4 scans
// that whole range (at most prior_max_range_px wide) at full resolution and
// rejects a best shift at either end; step 5 is the same. No right-image
// features are extracted.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "tracker/orb_extractor.h"

namespace dypho {

struct StereoFeatureOptions {
  double baseline = 0.0;         // [m] right camera's x offset from the left (rectified), >= 0 (0 = off)
  double min_disparity = 1.0;    // [px] smallest disparity (farthest depth = fx * baseline / it), > 0
  double max_disparity = 128.0;  // [px] largest disparity, > min_disparity
  double row_band_px = 2.0;      // [px] x level scale: rows a right feature serves on each side, >= 0
  int max_distance = 75;         // [bits] largest Hamming distance of a match, 1..256
  double ratio = 0.9;            // best / second-best distance limit, (0, 1]
  int window_px = 11;            // SAD patch size (odd), 3..31
  int search_px = 5;             // SAD search either side of the descriptor match [px], 1..20
  double outlier_factor = 2.1;   // matches with SAD above this x median are dropped (ORB-SLAM2: 1.5 x 1.4), >= 1
  // With a prior (StereoFeatureDepthsFromPrior): the search beyond the
  // prior's disparity range either side [px], 1..20, and the widest range
  // scanned [px] (wider, e.g. across a depth edge: no depth), >= 3.
  int prior_search_px = 3;
  int prior_max_range_px = 48;

  bool IsValid(std::string* error) const;
};

struct StereoFeatureStats {
  int left = 0;       // left features
  int right = 0;      // right features extracted
  int matched = 0;    // with a depth
};

// Depth [m] for each left feature (0 = none). `left_gray` / `right_gray`:
// the rectified pair, CV_8UC1, same size. `fx`: the focal length [px].
std::vector<float> StereoFeatureDepths(const OrbFeatures& left, const OrbFeatures& right, const cv::Mat& left_gray,
                                       const cv::Mat& right_gray, double fx, double scale_factor,
                                       const StereoFeatureOptions& options, StereoFeatureStats* stats = nullptr);

// The same from a coarse depth prior instead of right-image features (see the
// top). `prior_depth`: CV_32FC1 [m], 0 or non-finite = none, the image size
// divided by an integer n >= 1 in both directions (pixel (x, y) of the prior
// covers image pixels [n x, n x + n) x [n y, n y + n)).
std::vector<float> StereoFeatureDepthsFromPrior(const OrbFeatures& left, const cv::Mat& prior_depth,
                                                const cv::Mat& left_gray, const cv::Mat& right_gray, double fx,
                                                const StereoFeatureOptions& options,
                                                StereoFeatureStats* stats = nullptr);

}  // namespace dypho
