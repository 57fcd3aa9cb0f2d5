#include "engine/stereo/stereo_dataset.h"

#include <cstring>
#include <filesystem>
#include <memory>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/stereo/pair_depth.h"

namespace dypho::stereo {
namespace fs = std::filesystem;

namespace internal {
cv::Size ImageSize(const std::string& path) {
  const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  DYPHO_CHECK_INPUT(!image.empty()) << path << ": not a readable image";
  return image.size();
}

void CheckPairsExist(const Dataset::Contents& c) {
  for (const FrameInfo& f : c.frames) {
    DYPHO_CHECK_INPUT(fs::exists(f.rgb_path)) << f.rgb_path << ": missing left image (" << f.rgb_source << ")";
    DYPHO_CHECK_INPUT(fs::exists(f.right_path))
        << f.right_path << ": missing right image for " << f.rgb_path << " (" << f.rgb_source << ")";
  }
}
}  // namespace internal

std::optional<Dataset::Contents> OpenStereoContents(const std::string& folder, const DatasetOptions& options) {
  std::optional<Dataset::Contents> c = internal::OpenKitti(folder);
  if (!c) c = internal::OpenEuroc(folder, options);
  if (!c) c = internal::OpenGenericStereo(folder, options);
  if (c) {
    auto rig = std::make_shared<StereoRig>(*c->stereo);
    rig->disparity.method = ParseDisparityMethod(options.stereo_method);
    c->stereo = rig;
  }
  return c;
}

namespace {
cv::Mat ReadImage(const std::string& path, const std::string& source) {
  const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  DYPHO_CHECK_INPUT(!image.empty()) << path << ": not a readable image (" << source << ")";
  DYPHO_CHECK_INPUT(image.depth() == CV_8U) << path << ": an 8-bit image is needed (" << source << ")";
  return image;
}

ImageU8 ToRgbImage(const cv::Mat& image) {
  cv::Mat rgb;
  if (image.channels() == 1) cv::cvtColor(image, rgb, cv::COLOR_GRAY2RGB);
  else if (image.channels() == 4) cv::cvtColor(image, rgb, cv::COLOR_BGRA2RGB);
  else cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
  ImageU8 out(rgb.cols, rgb.rows, 3);
  for (int y = 0; y < rgb.rows; ++y) std::memcpy(out.data() + size_t(y) * rgb.cols * 3, rgb.ptr(y), rgb.cols * 3);
  return out;
}
}  // namespace

Frame LoadStereoFrame(const StereoRig& rig, const FrameInfo& info) {
  cv::Mat left = ReadImage(info.rgb_path, info.rgb_source), right = ReadImage(info.right_path, info.rgb_source);
  DYPHO_CHECK_INPUT(left.size() == right.size())
      << "stereo images differ in size: " << info.rgb_path << " is " << left.cols << "x" << left.rows << ", "
      << info.right_path << " is " << right.cols << "x" << right.rows;
  DYPHO_CHECK_INPUT(left.cols == rig.camera.width && left.rows == rig.camera.height)
      << info.rgb_path << " is " << left.cols << "x" << left.rows << " but the calibration (" << rig.source
      << ") is " << rig.camera.width << "x" << rig.camera.height;
  RectifyPair(rig, left, right);
  double seconds = 0.0;
  const cv::Mat depth = PairDepth(left, right, rig.disparity, rig.camera.fx, rig.baseline, rig.min_disparity_for_depth,
                                  rig.preview_downscale, &seconds);
  Frame frame;
  frame.depth_downscale = rig.preview_downscale;
  frame.disparity_ms = 1000.0 * seconds;
  frame.index = info.index;
  frame.timestamp = info.timestamp;
  frame.rgb_path = info.rgb_path;
  frame.world_from_cam_gt = info.world_from_cam_gt;
  frame.rgb = ToRgbImage(left);
  frame.right = ToRgbImage(right);
  frame.depth = ImageF(depth.cols, depth.rows, 1);
  for (int y = 0; y < depth.rows; ++y)
    std::memcpy(frame.depth.data() + size_t(y) * depth.cols, depth.ptr<float>(y), depth.cols * sizeof(float));
  frame.has_depth = true;
  return frame;
}

}  // namespace dypho::stereo
