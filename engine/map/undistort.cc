#include "engine/map/undistort.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"

namespace dypho {

struct Undistorter::Maps {
  cv::Mat map1, map2;  // CV_16SC2 + CV_16UC1 fixed-point maps
};

Undistorter::Undistorter(const Camera& camera) : pinhole_(camera) {
  pinhole_.distortion = {0, 0, 0, 0, 0};
  valid_ = ImageU8(camera.width, camera.height, 1, 255);
  if (!camera.HasDistortion()) return;
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(camera.distortion.data()));
  maps_ = std::make_unique<Maps>();
  cv::initUndistortRectifyMap(k, dist, cv::Mat(), k, cv::Size(camera.width, camera.height), CV_16SC2, maps_->map1,
                              maps_->map2);
  // Valid pixels: remap an all-255 image without interpolation, erode by one pixel.
  const ImageU8 ones(camera.width, camera.height, 1, 255);
  const cv::Mat src(camera.height, camera.width, CV_8UC1, const_cast<uint8_t*>(ones.data()));
  cv::Mat remapped;
  cv::remap(src, remapped, maps_->map1, maps_->map2, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  cv::Mat dst(camera.height, camera.width, CV_8UC1, valid_.data());
  cv::erode(remapped, dst, cv::Mat(), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar::all(0));
}

ImageU8 Undistorter::ExcludedPixels(const ImageU8& dynamic_mask) const {
  const ImageU8 mask = Mask(dynamic_mask);
  ImageU8 out(valid_.width(), valid_.height(), 1, 0);
  for (size_t i = 0; i < out.size(); ++i) {
    out.data()[i] = (!valid_.data()[i] || (!mask.empty() && mask.data()[i])) ? 255 : 0;
  }
  return out;
}

Undistorter::~Undistorter() = default;

namespace {

template <typename T>
Image<T> Remap(const Image<T>& in, const cv::Mat& map1, const cv::Mat& map2, int cv_type, int interpolation,
               const Camera& camera, const char* what) {
  DYPHO_CHECK_INPUT(in.width() == camera.width && in.height() == camera.height)
      << "undistort " << what << ": image is " << in.width() << "x" << in.height() << ", the camera "
      << camera.width << "x" << camera.height;
  Image<T> out(in.width(), in.height(), in.channels());
  const cv::Mat src(in.height(), in.width(), CV_MAKETYPE(cv_type, in.channels()), const_cast<T*>(in.data()));
  cv::Mat dst(out.height(), out.width(), CV_MAKETYPE(cv_type, out.channels()), out.data());
  cv::remap(src, dst, map1, map2, interpolation, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return out;
}

}  // namespace

ImageU8 Undistorter::Rgb(const ImageU8& image) const {
  if (!maps_) return image;
  return Remap(image, maps_->map1, maps_->map2, CV_8U, cv::INTER_LINEAR, pinhole_, "rgb");
}

ImageF Undistorter::Depth(const ImageF& depth) const {
  if (!maps_ || depth.empty()) return depth;
  return Remap(depth, maps_->map1, maps_->map2, CV_32F, cv::INTER_NEAREST, pinhole_, "depth");
}

ImageU8 Undistorter::Mask(const ImageU8& mask) const {
  if (!maps_ || mask.empty()) return mask;
  return Remap(mask, maps_->map1, maps_->map2, CV_8U, cv::INTER_NEAREST, pinhole_, "mask");
}

}  // namespace dypho
