// Input checks for cv::Mat arguments of the masking functions. Each throws
// dypho::InvalidInput naming the argument (`what`), the expected and the
// actual type or size.
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace dypho {

// "CV_8UC3", "CV_32FC1", ...
std::string MatTypeName(int type);
// "640x480"
std::string SizeText(const cv::Size& size);

// `image` must be non-empty, of `type`, and (when `size` is not empty) of `size`.
void CheckMat(const cv::Mat& image, int type, const cv::Size& size, const std::string& what);
// Like CheckMat but an empty `image` is allowed (optional inputs).
void CheckOptionalMat(const cv::Mat& image, int type, const cv::Size& size, const std::string& what);

}  // namespace dypho
