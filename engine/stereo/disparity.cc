#include "engine/stereo/disparity.h"

#include <chrono>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/stereo/methods.h"

namespace dypho::stereo {
namespace {

bool Fail(std::string* error, const std::string& message) {
  if (error) *error = message;
  return false;
}

cv::Mat ToGrey(const cv::Mat& image, const char* which) {
  if (image.empty()) throw InvalidInput(std::string("the ") + which + " stereo image is empty");
  if (image.depth() != CV_8U)
    throw InvalidInput(std::string("the ") + which + " stereo image must be 8-bit (grey or colour)");
  if (image.channels() == 1) return image;
  cv::Mat grey;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4) cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  else throw InvalidInput(std::string("the ") + which + " stereo image has " +
                          std::to_string(image.channels()) + " channels (1, 3 or 4 expected)");
  return grey;
}

}  // namespace

DisparityMethod ParseDisparityMethod(const std::string& name) {
  if (name == "elas") return DisparityMethod::kElas;
  if (name == "sgbm") return DisparityMethod::kSgbm;
  throw InvalidInput("unknown disparity method '" + Printable(name) + "' (elas or sgbm)");
}

const char* DisparityMethodName(DisparityMethod method) {
  return method == DisparityMethod::kElas ? "elas" : "sgbm";
}

bool ElasOptions::IsValid(std::string* error) const {
  if (min_disparity < 0) return Fail(error, "elas.min_disparity must be >= 0");
  if (max_disparity <= min_disparity + 2 || max_disparity > 255)
    return Fail(error, "elas.max_disparity must be in (min_disparity + 2, 255]");
  if (candidate_step < 2) return Fail(error, "elas.candidate_step must be >= 2");
  if (!(support_ratio > 0 && support_ratio <= 1)) return Fail(error, "elas.support_ratio must be in (0, 1]");
  if (support_texture < 0 || match_texture < 0) return Fail(error, "elas texture thresholds must be >= 0");
  if (support_lr_threshold < 0 || lr_threshold < 0) return Fail(error, "elas lr thresholds must be >= 0");
  if (incon_window < 1 || incon_threshold < 0 || incon_min_support < 0)
    return Fail(error, "elas.incon_window must be >= 1, incon_threshold and incon_min_support >= 0");
  if (!(beta > 0) || !(gamma > 0) || !(sigma > 0)) return Fail(error, "elas beta, gamma, sigma must be > 0");
  if (plane_radius < 0) return Fail(error, "elas.plane_radius must be >= 0");
  if (grid_size < 1) return Fail(error, "elas.grid_size must be >= 1");
  if (grid_radius < 0) return Fail(error, "elas.grid_radius must be >= 0");
  if (speckle_size < 0 || !(speckle_threshold >= 0)) return Fail(error, "elas speckle options must be >= 0");
  if (gap_width < 0 || !(gap_smooth_threshold >= 0)) return Fail(error, "elas gap options must be >= 0");
  if (threads < 0) return Fail(error, "elas.threads must be >= 0");
  return true;
}

bool SgbmOptions::IsValid(std::string* error) const {
  if (min_disparity < 0) return Fail(error, "sgbm.min_disparity must be >= 0");
  if (max_disparity <= min_disparity) return Fail(error, "sgbm.max_disparity must be > min_disparity");
  if (block_size < 1 || block_size % 2 == 0) return Fail(error, "sgbm.block_size must be odd and >= 1");
  if (p1_per_pixel < 0 || p2_per_pixel <= p1_per_pixel)
    return Fail(error, "sgbm.p2_per_pixel must be > p1_per_pixel >= 0");
  return true;
}

void DisparityOptions::SetMaxDisparity(int max_disparity) {
  elas.max_disparity = max_disparity;
  sgbm.max_disparity = max_disparity;
}

DisparityResult ComputeDisparity(const cv::Mat& left, const cv::Mat& right, const DisparityOptions& options) {
  const cv::Mat left_grey = ToGrey(left, "left"), right_grey = ToGrey(right, "right");
  if (left_grey.size() != right_grey.size())
    throw InvalidInput("stereo images differ in size: left " + std::to_string(left.cols) + "x" +
                       std::to_string(left.rows) + ", right " + std::to_string(right.cols) + "x" +
                       std::to_string(right.rows));
  std::string error;
  const bool valid = options.method == DisparityMethod::kElas ? options.elas.IsValid(&error)
                                                              : options.sgbm.IsValid(&error);
  if (!valid) throw InvalidInput(error);
  const auto start = std::chrono::steady_clock::now();
  DisparityResult result = options.method == DisparityMethod::kElas
                               ? ComputeElas(left_grey, right_grey, options.elas)
                               : ComputeSgbm(left_grey, right_grey, options.sgbm);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

cv::Mat DisparityToDepth(const cv::Mat& disparity, const cv::Mat& valid, double focal_px, double baseline_m,
                         double min_disparity) {
  if (!(focal_px > 0) || !(baseline_m > 0) || !std::isfinite(focal_px * baseline_m))
    throw InvalidInput("disparity to depth needs a finite focal length and baseline > 0 (got fx " +
                       std::to_string(focal_px) + ", baseline " + std::to_string(baseline_m) + ")");
  CV_Assert(disparity.type() == CV_32F && valid.type() == CV_8U && disparity.size() == valid.size());
  cv::Mat depth(disparity.size(), CV_32F, cv::Scalar(0));
  const float fb = float(focal_px * baseline_m);
  for (int v = 0; v < disparity.rows; ++v) {
    const float* d = disparity.ptr<float>(v);
    const uint8_t* ok = valid.ptr<uint8_t>(v);
    float* z = depth.ptr<float>(v);
    for (int u = 0; u < disparity.cols; ++u)
      if (ok[u] && d[u] > min_disparity) z[u] = fb / d[u];
  }
  return depth;
}

cv::Mat DisparityToKitti16(const cv::Mat& disparity, const cv::Mat& valid) {
  CV_Assert(disparity.type() == CV_32F && valid.type() == CV_8U);
  cv::Mat out(disparity.size(), CV_16U, cv::Scalar(0));
  for (int v = 0; v < disparity.rows; ++v)
    for (int u = 0; u < disparity.cols; ++u)
      if (valid.at<uint8_t>(v, u))
        out.at<uint16_t>(v, u) = cv::saturate_cast<uint16_t>(std::max(1.0, std::round(disparity.at<float>(v, u) * 256.0)));
  return out;
}

cv::Mat DisparityToColour(const cv::Mat& disparity, const cv::Mat& valid, float max_disparity) {
  cv::Mat scaled;
  disparity.convertTo(scaled, CV_8U, 255.0 / std::max(1.f, max_disparity));
  cv::Mat colour;
  cv::applyColorMap(scaled, colour, cv::COLORMAP_JET);
  colour.setTo(cv::Scalar(0, 0, 0), ~valid);
  return colour;
}

}  // namespace dypho::stereo
