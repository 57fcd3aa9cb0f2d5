// cv::Mat views of common Image types (no copy): the returned Mat points into
// the image's pixels and is valid while the image lives and is not resized.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "common/image.h"

namespace dypho {

inline cv::Mat CvView(const Image<uint8_t>& image) {
  if (image.empty()) return cv::Mat();
  return cv::Mat(image.height(), image.width(), CV_8UC(image.channels()), const_cast<uint8_t*>(image.data()));
}

inline cv::Mat CvView(const Image<float>& image) {
  if (image.empty()) return cv::Mat();
  return cv::Mat(image.height(), image.width(), CV_32FC(image.channels()), const_cast<float*>(image.data()));
}

}  // namespace dypho
