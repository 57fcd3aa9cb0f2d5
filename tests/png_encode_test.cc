// Our PNG encoder (engine/io/png_encode.h) writes ordinary PNGs: OpenCV's
// decoder and ours read back every sample exactly, for 8-bit grey and RGB
// and 16-bit grey, odd sizes, noise and flat images; bad shapes throw.
#include "engine/io/png_encode.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "engine/io/png_decode.h"

namespace dypho {
namespace {

template <typename T>
std::vector<T> Pixels(int w, int h, int c, bool noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<T> v(static_cast<size_t>(w) * h * c);
  for (size_t i = 0; i < v.size(); ++i)
    v[i] = noise ? static_cast<T>(rng()) : static_cast<T>((i / c) % 7 * 1000 + i % c);
  return v;
}

TEST(PngEncode, EightBitReadBackExactlyByOpenCvAndOurs) {
  for (int c : {1, 3}) {
    for (auto [w, h] : {std::pair{1, 1}, std::pair{17, 5}, std::pair{640, 480}}) {
      for (bool noise : {false, true}) {
        const std::vector<uint8_t> px = Pixels<uint8_t>(w, h, c, noise, w * 31 + c);
        const std::vector<uint8_t> png = EncodePng8(px.data(), w, h, c);
        PngPixels ours;
        ASSERT_TRUE(DecodePngFast(png, c == 3 ? PngWant::kRgb8 : PngWant::kGray8, &ours)) << w << "x" << h << "x" << c;
        ASSERT_EQ(ours.width, w);
        ASSERT_EQ(ours.height, h);
        EXPECT_EQ(ours.bytes8, px);
        cv::Mat cv_img = cv::imdecode(png, cv::IMREAD_UNCHANGED);
        ASSERT_EQ(cv_img.channels(), c);
        if (c == 3) cv::cvtColor(cv_img, cv_img, cv::COLOR_BGR2RGB);
        ASSERT_TRUE(cv_img.isContinuous());
        EXPECT_EQ(std::vector<uint8_t>(cv_img.data, cv_img.data + px.size()), px);
      }
    }
  }
}

TEST(PngEncode, SixteenBitReadBackExactly) {
  for (bool noise : {false, true}) {
    const std::vector<uint16_t> px = Pixels<uint16_t>(33, 9, 1, noise, 5);
    const std::vector<uint8_t> png = EncodePng16(px.data(), 33, 9);
    PngPixels ours;
    ASSERT_TRUE(DecodePngFast(png, PngWant::kGray16, &ours));
    EXPECT_EQ(ours.bytes16, px);
    const cv::Mat cv_img = cv::imdecode(png, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(cv_img.type(), CV_16UC1);
    EXPECT_EQ(std::vector<uint16_t>(cv_img.ptr<uint16_t>(), cv_img.ptr<uint16_t>() + px.size()), px);
  }
}

TEST(PngEncode, CompressesSmoothImagesAndRejectsBadShapes) {
  const std::vector<uint8_t> flat(640 * 480 * 3, 128);
  EXPECT_LT(EncodePng8(flat.data(), 640, 480, 3).size(), flat.size() / 50);
  EXPECT_THROW(EncodePng8(flat.data(), 640, 480, 2), std::exception);
  EXPECT_THROW(EncodePng8(flat.data(), 0, 480, 3), std::exception);
}

}  // namespace
}  // namespace dypho
