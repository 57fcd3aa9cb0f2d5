#include "masking/shore_segmentation.h"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/check.h"
#include "masking/mat_checks.h"

namespace dypho {
namespace {

void Morph(cv::Mat& image, int op, int px, double scale) {
  if (px <= 1) return;
  const int k = std::max(1, static_cast<int>(std::lround(px * scale)));
  if (k <= 1) return;
  cv::morphologyEx(image, image, op, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k)));
}

}  // namespace

bool ShoreOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (erode_px < 0 || erode_px > 101)
    msg << "erode_px must be in 0..101 (got " << erode_px << ")";
  else if (dilate_px < 0 || dilate_px > 101)
    msg << "dilate_px must be in 0..101 (got " << dilate_px << ")";
  else if (final_erode_px < 0 || final_erode_px > 101)
    msg << "final_erode_px must be in 0..101 (got " << final_erode_px << ")";
  else if (!(scale > 0 && scale <= 1))
    msg << "scale must be in (0, 1] (got " << scale << ")";
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

ShoreSegmentation SegmentShore(const cv::Mat& rgb, const ShoreOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "ShoreOptions." << error;
  CheckMat(rgb, CV_8UC3, cv::Size(), "rgb");
  cv::Mat small = rgb;
  if (options.scale < 1.0) cv::resize(rgb, small, cv::Size(), options.scale, options.scale, cv::INTER_AREA);
  // 1. Hue.
  cv::Mat hsv, hue;
  cv::cvtColor(small, hsv, cv::COLOR_RGB2HSV);
  cv::extractChannel(hsv, hue, 0);
  // 2. Otsu: 255 = high-hue class.
  ShoreSegmentation result;
  cv::Mat shore;
  result.otsu_hue = cv::threshold(hue, shore, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  // 3. Inversion: the shore (the class that is not water/sky) becomes 255.
  if (options.water_hue_high) cv::bitwise_not(shore, shore);
  // 4. Erode, dilate, erode.
  Morph(shore, cv::MORPH_ERODE, options.erode_px, options.scale);
  Morph(shore, cv::MORPH_DILATE, options.dilate_px, options.scale);
  Morph(shore, cv::MORPH_ERODE, options.final_erode_px, options.scale);
  // 5. Water and sky = not shore, at the image size.
  cv::Mat water_sky;
  cv::bitwise_not(shore, water_sky);
  if (options.scale < 1.0) {
    cv::resize(water_sky, result.water_sky, rgb.size(), 0, 0, cv::INTER_LINEAR);
    cv::threshold(result.water_sky, result.water_sky, 127, 255, cv::THRESH_BINARY);
  } else {
    result.water_sky = water_sky;
  }
  return result;
}

}  // namespace dypho
