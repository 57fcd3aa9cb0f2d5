// The two disparity methods behind ComputeDisparity (engine/stereo/disparity.h).
// Inputs are validated 8-bit grey images of one size; options are valid.
#pragma once

#include "engine/stereo/disparity.h"

namespace dypho::stereo {

DisparityResult ComputeElas(const cv::Mat& left_grey, const cv::Mat& right_grey, const ElasOptions& options);
DisparityResult ComputeSgbm(const cv::Mat& left_grey, const cv::Mat& right_grey, const SgbmOptions& options);

}  // namespace dypho::stereo
