// Depth of a rectified stereo pair: the one place that turns a pair into a
// depth image, used by the stereo datasets' frame loader (stereo_dataset.h)
// and by the engine for pushed pairs (engine/api_frames.cc), so that both
// give the same depth bit for bit.
#pragma once

#include <opencv2/core.hpp>

#include "engine/stereo/disparity.h"

namespace dypho::stereo {

// Depth [m] (CV_32F, the pair's size; 0 = none) of a rectified pair (8-bit
// grey or BGR, same size): focal_px x baseline_m / d where the disparity d
// was matched (confidence > 0) and d >= min_disparity [px].
//
// downscale > 1 gives a preview: the disparity of the pair resized to
// 1/downscale (cv::INTER_AREA, max_disparity / downscale searched), its
// values times downscale, upsampled to the pair's size (nearest neighbour)
// before the depth; ELAS's lengths in pixels (candidate_step, grid_size,
// speckle_size) are scaled with the image (on kitti_stereo_51 this took the
// sequential run's ATE from 1.03 % to 0.96 % of the path, full depth 0.93 %). About 1/downscale^2 of the cost, for per-frame work
// that reads depth at coarse resolution (masks at masking_downscale, the
// keyframe selector's 10 px grid). `seconds` (optional) gets the disparity's
// wall time.
cv::Mat PairDepth(const cv::Mat& left, const cv::Mat& right, const DisparityOptions& options, double focal_px,
                  double baseline_m, double min_disparity, int downscale = 1, double* seconds = nullptr);

}  // namespace dypho::stereo
