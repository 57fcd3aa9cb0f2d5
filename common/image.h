// Images as plain row-major, channel-interleaved buffers. `Image<T>` owns
// its pixels; `ImageView<T>` points into memory owned by someone else (a
// tensor, a cv::Mat, a caller's buffer).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "common/check.h"

namespace dypho {

template <typename T>
struct ImageView {
  T* data = nullptr;
  int width = 0;
  int height = 0;
  int channels = 1;

  bool empty() const { return data == nullptr || width <= 0 || height <= 0; }
  size_t size() const { return static_cast<size_t>(width) * height * channels; }
  T& at(int x, int y, int c = 0) const {
    return data[(static_cast<size_t>(y) * width + x) * channels + c];
  }
};

template <typename T>
class Image {
 public:
  Image() = default;
  Image(int width, int height, int channels, T fill = T())
      : width_(width), height_(height), channels_(channels) {
    DYPHO_CHECK_INPUT(width >= 0 && height >= 0 && channels > 0)
        << "image size " << width << "x" << height << "x" << channels << " is invalid";
    pixels_.assign(static_cast<size_t>(width) * height * channels, fill);
  }
  // Takes `pixels` (row-major, channels interleaved; width * height * channels values).
  Image(int width, int height, int channels, std::vector<T>&& pixels)
      : width_(width), height_(height), channels_(channels), pixels_(std::move(pixels)) {
    DYPHO_CHECK_INPUT(width >= 0 && height >= 0 && channels > 0 &&
                      pixels_.size() == static_cast<size_t>(width) * height * channels)
        << "image size " << width << "x" << height << "x" << channels << " does not fit " << pixels_.size()
        << " values";
  }

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return pixels_.empty(); }
  size_t size() const { return pixels_.size(); }
  T* data() { return pixels_.data(); }
  const T* data() const { return pixels_.data(); }
  T& at(int x, int y, int c = 0) { return pixels_[(static_cast<size_t>(y) * width_ + x) * channels_ + c]; }
  const T& at(int x, int y, int c = 0) const {
    return pixels_[(static_cast<size_t>(y) * width_ + x) * channels_ + c];
  }
  ImageView<T> view() { return {pixels_.data(), width_, height_, channels_}; }
  ImageView<const T> view() const { return {pixels_.data(), width_, height_, channels_}; }
  std::vector<T>& pixels() { return pixels_; }
  const std::vector<T>& pixels() const { return pixels_; }

 private:
  int width_ = 0;
  int height_ = 0;
  int channels_ = 1;
  std::vector<T> pixels_;
};

using ImageF = Image<float>;
using ImageU8 = Image<uint8_t>;

}  // namespace dypho
