#include "engine/stereo/descriptor.h"

#include <opencv2/imgproc.hpp>

namespace dypho::stereo {

cv::Mat ComputeDescriptors(const cv::Mat& grey) {
  CV_Assert(grey.type() == CV_8UC1);
  cv::Mat du16, dv16;
  cv::Sobel(grey, du16, CV_16S, 1, 0, 3, 1, 0, cv::BORDER_REPLICATE);
  cv::Sobel(grey, dv16, CV_16S, 0, 1, 3, 1, 0, cv::BORDER_REPLICATE);
  cv::Mat du, dv;  // 8-bit: 128 + r / 4, saturated
  du16.convertTo(du, CV_8U, 0.25, 128);
  dv16.convertTo(dv, CV_8U, 0.25, 128);
  // Pad by 2 so every sample offset stays inside.
  cv::Mat du_pad, dv_pad;
  cv::copyMakeBorder(du, du_pad, 2, 2, 2, 2, cv::BORDER_REPLICATE);
  cv::copyMakeBorder(dv, dv_pad, 2, 2, 2, 2, cv::BORDER_REPLICATE);
  static const int kDu[11][2] = {{-1, -1}, {0, -1}, {1, -1}, {-1, 0}, {0, 0}, {1, 0},
                                 {-1, 1},  {0, 1},  {1, 1},  {-2, 0}, {2, 0}};
  static const int kDv[5][2] = {{0, 0}, {0, -1}, {0, 1}, {-1, 0}, {1, 0}};
  const int w = grey.cols, h = grey.rows;
  cv::Mat descriptors(h, w, CV_8UC(kDescriptorBytes));
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const uint8_t* du_rows[3] = {du_pad.ptr<uint8_t>(y + 1) + 2, du_pad.ptr<uint8_t>(y + 2) + 2,
                                   du_pad.ptr<uint8_t>(y + 3) + 2};
      const uint8_t* dv_rows[3] = {dv_pad.ptr<uint8_t>(y + 1) + 2, dv_pad.ptr<uint8_t>(y + 2) + 2,
                                   dv_pad.ptr<uint8_t>(y + 3) + 2};
      uint8_t* out = descriptors.ptr<uint8_t>(y);
      for (int x = 0; x < w; ++x, out += kDescriptorBytes) {
        for (int k = 0; k < 11; ++k) out[k] = du_rows[kDu[k][1] + 1][x + kDu[k][0]];
        for (int k = 0; k < 5; ++k) out[11 + k] = dv_rows[kDv[k][1] + 1][x + kDv[k][0]];
      }
    }
  });
  return descriptors;
}

cv::Mat DescriptorTexture(const cv::Mat& descriptors) {
  cv::Mat texture(descriptors.rows, descriptors.cols, CV_16U);
  for (int y = 0; y < descriptors.rows; ++y) {
    const uint8_t* d = descriptors.ptr<uint8_t>(y);
    uint16_t* t = texture.ptr<uint16_t>(y);
    for (int x = 0; x < descriptors.cols; ++x, d += kDescriptorBytes) {
      int sum = 0;
      for (int k = 0; k < kDescriptorBytes; ++k) sum += std::abs(int(d[k]) - 128);
      t[x] = static_cast<uint16_t>(sum);
    }
  }
  return texture;
}

}  // namespace dypho::stereo
