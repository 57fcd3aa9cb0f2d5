// ImageSharpness (engine/map/image_sharpness.h, plain C++) against the
// OpenCV formulation it replaced (below, as it was in
// engine/map/keyframe_selector.cc): every step equal pixel for pixel and the
// result equal to the last bit, on random images of even and odd sizes (the
// exact halving and the general area path), with and without masks, and on
// real frames (TUM 640x480, KITTI 1241x376, a 752x480 crop).
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "engine/io/image_io.h"
#include "engine/map/image_sharpness.h"
#include "tests/test_data.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

// The OpenCV formulation, step by step.
struct OpenCvSteps {
  cv::Mat grey, half, lap, static_mask;
  double sharpness = 0.0;
};

OpenCvSteps OpenCvSharpness(const ImageU8& rgb, const ImageU8& dynamic_mask) {
  OpenCvSteps s;
  if (rgb.channels() == 3) {
    cv::cvtColor(CvView(rgb), s.grey, cv::COLOR_RGB2GRAY);
  } else {
    s.grey = CvView(rgb);
  }
  cv::resize(s.grey, s.half, cv::Size(s.grey.cols / 2, s.grey.rows / 2), 0, 0, cv::INTER_AREA);
  cv::Laplacian(s.half, s.lap, CV_32F);
  if (!dynamic_mask.empty()) {
    cv::Mat small;
    cv::resize(CvView(dynamic_mask), small, s.half.size(), 0, 0, cv::INTER_NEAREST);
    s.static_mask = small == 0;
    cv::erode(s.static_mask, s.static_mask, cv::Mat(), cv::Point(-1, -1), 2);
    if (cv::countNonZero(s.static_mask) < 100) return s;
  }
  cv::Scalar mean, stddev;
  cv::meanStdDev(s.lap, mean, stddev, s.static_mask);
  s.sharpness = stddev[0] * stddev[0];
  return s;
}

template <typename T>
bool SameAs(const Image<T>& image, const cv::Mat& mat) {
  if (image.width() != mat.cols || image.height() != mat.rows || mat.channels() != 1) return false;
  for (int y = 0; y < mat.rows; ++y) {
    if (std::memcmp(&image.at(0, y), mat.ptr<T>(y), sizeof(T) * mat.cols) != 0) return false;
  }
  return true;
}

// Smooth texture plus noise: Laplacians of every size, rounding ties in the
// area path.
ImageU8 RandomImage(int w, int h, int channels, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(-40, 40);
  ImageU8 im(w, h, channels);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < channels; ++c) {
        const double base = 128 + 80 * std::sin(0.11 * x + 0.7 * c) * std::cos(0.07 * y - 0.3 * c);
        im.at(x, y, c) = static_cast<uint8_t>(std::clamp<int>(static_cast<int>(base) + noise(rng), 0, 255));
      }
    }
  }
  return im;
}

// Random rectangles of "dynamic" (non-zero) pixels.
ImageU8 RandomMask(int w, int h, uint32_t seed, int boxes) {
  std::mt19937 rng(seed);
  ImageU8 m(w, h, 1, 0);
  for (int b = 0; b < boxes; ++b) {
    const int x0 = std::uniform_int_distribution<int>(0, w - 1)(rng);
    const int y0 = std::uniform_int_distribution<int>(0, h - 1)(rng);
    const int bw = std::uniform_int_distribution<int>(1, std::max(1, w / 3))(rng);
    const int bh = std::uniform_int_distribution<int>(1, std::max(1, h / 3))(rng);
    for (int y = y0; y < std::min(h, y0 + bh); ++y) {
      for (int x = x0; x < std::min(w, x0 + bw); ++x) m.at(x, y) = static_cast<uint8_t>(1 + b % 200);
    }
  }
  return m;
}

void ExpectEqualToOpenCv(const ImageU8& rgb, const ImageU8& mask, const std::string& what) {
  SCOPED_TRACE(what);
  const OpenCvSteps cv = OpenCvSharpness(rgb, mask);
  const ImageU8 grey = sharpness_steps::Grey(rgb);
  ASSERT_TRUE(SameAs(grey, cv.grey)) << "grey";
  const ImageU8 half = sharpness_steps::HalfArea(grey);
  ASSERT_TRUE(SameAs(half, cv.half)) << "half";
  if (rgb.channels() == 3 && rgb.width() % 2 == 0 && rgb.height() % 2 == 0)
    ASSERT_TRUE(SameAs(sharpness_steps::HalfGreyOfRgb(rgb), cv.half)) << "half grey in one pass";
  ASSERT_TRUE(SameAs(sharpness_steps::Laplacian(half), cv.lap)) << "laplacian";
  if (!mask.empty()) {
    ASSERT_TRUE(SameAs(sharpness_steps::StaticMask(mask, half.width(), half.height()), cv.static_mask)) << "mask";
  }
  const double ours = ImageSharpness(rgb, mask);
  // Equal to the last bit (not only close).
  EXPECT_EQ(std::memcmp(&ours, &cv.sharpness, sizeof(double)), 0) << ours << " vs OpenCV " << cv.sharpness;
}

TEST(ImageSharpness, EqualsTheOpenCvFormulationOnRandomImages) {
  // Exact halvings, odd widths and heights (the general area path), tiny ones.
  const int sizes[][2] = {{640, 480}, {320, 240}, {1241, 376}, {752, 481}, {17, 13}, {33, 34}, {34, 33},
                          {160, 120}, {5, 4},     {3, 3},     {2, 2}};
  uint32_t seed = 1;
  int checked = 0;
  for (const auto& s : sizes) {
    for (int channels : {3, 1}) {
      const ImageU8 rgb = RandomImage(s[0], s[1], channels, seed++);
      const std::string name = std::to_string(s[0]) + "x" + std::to_string(s[1]) + "x" + std::to_string(channels);
      ExpectEqualToOpenCv(rgb, ImageU8(), name + ", no mask");
      ExpectEqualToOpenCv(rgb, RandomMask(s[0], s[1], seed++, 4), name + ", mask");
      ExpectEqualToOpenCv(rgb, RandomMask(s[0], s[1], seed++, 40), name + ", mostly masked");
      checked += 3;
    }
  }
  // A mask of another size than the image (read by nearest neighbour).
  ExpectEqualToOpenCv(RandomImage(640, 480, 3, 99), RandomMask(320, 240, 100, 3), "mask at half size");
  EXPECT_EQ(checked, 66);
  // Sanity: sharper texture, larger value (the quantity is meaningful).
  ImageU8 flat(64, 48, 3, 90);
  EXPECT_EQ(ImageSharpness(flat, ImageU8()), 0.0);
  EXPECT_GT(ImageSharpness(RandomImage(64, 48, 3, 5), ImageU8()), 10.0);
}

TEST(ImageSharpness, GreyEqualsOpenCvOnEveryColour) {
  ImageU8 all(4096, 4096, 3);
  for (int i = 0; i < 4096 * 4096; ++i) {
    for (int c = 0; c < 3; ++c) all.data()[3 * i + c] = static_cast<uint8_t>(i >> (8 * c));
  }
  cv::Mat grey;
  cv::cvtColor(CvView(all), grey, cv::COLOR_RGB2GRAY);
  EXPECT_TRUE(SameAs(sharpness_steps::Grey(all), grey));
}

TEST(ImageSharpness, EqualsTheOpenCvFormulationOnRealFrames) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const std::string tum = testing::SharedData("tum_fr1_rpy_head250/rgb/");
  const std::vector<std::string> frames = {"1305031229.528748.png", "1305031229.564425.png", "1305031229.596600.png"};
  int n = 0;
  for (const std::string& f : frames) {
    const ImageU8 rgb = ReadRgb8(tum + f);
    ExpectEqualToOpenCv(rgb, ImageU8(), f);
    ExpectEqualToOpenCv(rgb, RandomMask(rgb.width(), rgb.height(), 7 + n, 3), f + " with a mask");
    // A 752x480 crop (EuRoC's size: odd half-width path on x only).
    ImageU8 crop(752, 480, 3);
    for (int y = 0; y < 480; ++y) {
      for (int x = 0; x < 752; ++x) {
        for (int c = 0; c < 3; ++c) crop.at(x, y, c) = rgb.at(x % 640, y, c);
      }
    }
    ExpectEqualToOpenCv(crop, ImageU8(), f + " 752x480");
    ++n;
  }
  const ImageU8 kitti = ReadRgb8(testing::SharedData("kitti_stereo_51/image_0/000000.png"));
  ASSERT_EQ(kitti.width(), 1241);
  ExpectEqualToOpenCv(kitti, ImageU8(), "KITTI 1241x376");
  ExpectEqualToOpenCv(kitti, RandomMask(kitti.width(), kitti.height(), 3, 5), "KITTI with a mask");
}

}  // namespace
}  // namespace dypho
