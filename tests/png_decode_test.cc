// The libdeflate PNG path (engine/io/png_decode.h) gives exactly OpenCV's
// pixels: every frame of the shared TUM sequences (colour and depth), and
// written PNGs of each kind it takes and each filter type libpng chooses;
// other kinds and damaged files fall back to OpenCV (same pixels, same
// errors naming the file).
#include "engine/io/png_decode.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/io/image_io.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using ::dypho::testing::SharedData;
using ::dypho::testing::TestTempDir;

std::vector<uint8_t> Bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// OpenCV's pixels as ReadRgb8 / ReadGray8 / ReadDepth16 would give them.
cv::Mat OpenCvRgb(const std::string& path) {
  cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR), rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

bool Same(const PngPixels& px, const cv::Mat& m) {
  if (px.width != m.cols || px.height != m.rows || px.channels != m.channels()) return false;
  const size_t row = static_cast<size_t>(m.cols) * m.channels();
  for (int y = 0; y < m.rows; ++y) {
    if (m.depth() == CV_16U) {
      if (std::memcmp(px.bytes16.data() + y * row, m.ptr(y), row * 2) != 0) return false;
    } else if (std::memcmp(px.bytes8.data() + y * row, m.ptr(y), row) != 0) {
      return false;
    }
  }
  return true;
}

TEST(PngDecode, EveryTumFrameAsOpenCvDecodesIt) {
  for (const char* sequence : {"tum_fr1_rpy_head250", "tum_fr3_walking_xyz_3frames"}) {
    DYPHO_REQUIRE_SHARED_DATA(sequence);
    int colour = 0, depth = 0;
    for (const char* folder : {"rgb", "depth"}) {
      for (const auto& entry : fs::directory_iterator(SharedData(sequence) + "/" + folder)) {
        if (entry.path().extension() != ".png") continue;
        const std::string path = entry.path().string();
        PngPixels px;
        if (std::string(folder) == "rgb") {
          ASSERT_TRUE(DecodePngFast(Bytes(path), PngWant::kRgb8, &px)) << path;
          ASSERT_TRUE(Same(px, OpenCvRgb(path))) << path;
          ++colour;
        } else {
          ASSERT_TRUE(DecodePngFast(Bytes(path), PngWant::kGray16, &px)) << path;
          ASSERT_TRUE(Same(px, cv::imread(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR))) << path;
          ++depth;
        }
      }
    }
    std::printf("%s: %d colour and %d depth frames the same as OpenCV's\n", sequence, colour, depth);
    EXPECT_GT(colour, 0);
    EXPECT_GT(depth, 0);
  }
}

// Written PNGs: noise (libpng picks among all five filters row by row),
// gradients, every kind the fast path takes, odd sizes.
TEST(PngDecode, WrittenPngsOfEachKindAsOpenCvDecodesThem) {
  const std::string dir = TestTempDir();
  cv::RNG rng(7);
  int checked = 0;
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(7, 5), cv::Size(640, 480), cv::Size(333, 101)}) {
    for (int kind = 0; kind < 4; ++kind) {  // grey 8, BGR 8, BGRA 8, grey 16
      const int type = kind == 0 ? CV_8UC1 : kind == 1 ? CV_8UC3 : kind == 2 ? CV_8UC4 : CV_16UC1;
      cv::Mat image(size, type);
      rng.fill(image, cv::RNG::UNIFORM, 0, kind == 3 ? 65536 : 256);
      // Smooth parts too, where Sub, Up, Average and Paeth win.
      if (size.height >= 2) {
        cv::Mat smooth;
        cv::GaussianBlur(image, smooth, cv::Size(0, 0), 3.0);
        const cv::Rect top(0, 0, size.width, size.height / 2);
        cv::Mat roi = image(top);
        smooth(top).copyTo(roi);
      }
      for (int level : {0, 1, 9}) {
        const std::string path = dir + "/k" + std::to_string(kind) + "_" + std::to_string(size.width) + "_" +
                                 std::to_string(level) + ".png";
        ASSERT_TRUE(cv::imwrite(path, image, {cv::IMWRITE_PNG_COMPRESSION, level}));
        const std::vector<uint8_t> bytes = Bytes(path);
        PngPixels px;
        if (kind == 3) {
          ASSERT_TRUE(DecodePngFast(bytes, PngWant::kGray16, &px)) << path;
          ASSERT_TRUE(Same(px, cv::imread(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR))) << path;
          EXPECT_FALSE(DecodePngFast(bytes, PngWant::kRgb8, &px)) << "16-bit to RGB is OpenCV's";
        } else {
          ASSERT_TRUE(DecodePngFast(bytes, PngWant::kRgb8, &px)) << path;
          ASSERT_TRUE(Same(px, OpenCvRgb(path))) << path;
          if (kind == 0) {
            ASSERT_TRUE(DecodePngFast(bytes, PngWant::kGray8, &px)) << path;
            ASSERT_TRUE(Same(px, cv::imread(path, cv::IMREAD_GRAYSCALE))) << path;
          } else {
            EXPECT_FALSE(DecodePngFast(bytes, PngWant::kGray8, &px)) << "colour to grey is OpenCV's";
          }
          // The readers give the same (fast path or not).
          const ImageU8 rgb = ReadRgb8(path);
          const cv::Mat expected = OpenCvRgb(path);
          ASSERT_EQ(std::memcmp(rgb.data(), expected.data, expected.total() * 3), 0) << path;
        }
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 48);
}

TEST(PngDecode, OtherKindsAndDamageFallBackToOpenCv) {
  const std::string dir = TestTempDir();
  cv::Mat image(48, 64, CV_8UC3);
  cv::randu(image, 0, 256);
  const std::string path = dir + "/frame.png";
  ASSERT_TRUE(cv::imwrite(path, image));
  const std::vector<uint8_t> good = Bytes(path);
  PngPixels px;
  ASSERT_TRUE(DecodePngFast(good, PngWant::kRgb8, &px));
  // A flipped bit in the image data: the CRC fails, OpenCV decides (and
  // refuses it, naming the file).
  std::vector<uint8_t> damaged = good;
  damaged[good.size() / 2] ^= 0x10;
  EXPECT_FALSE(DecodePngFast(damaged, PngWant::kRgb8, &px));
  const std::string damaged_path = dir + "/damaged.png";
  std::ofstream(damaged_path, std::ios::binary).write(reinterpret_cast<const char*>(damaged.data()), damaged.size());
  try {
    ReadRgb8(damaged_path);
    ADD_FAILURE() << "a damaged PNG was read";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("damaged.png"), std::string::npos) << e.what();
  }
  // A small file whose header claims 16000 x 8000 pixels: refused before
  // its 384 MB buffer is allocated (deflate cannot expand that much).
  std::vector<uint8_t> huge = good;
  auto put32 = [&](size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i) huge[at + i] = static_cast<uint8_t>(v >> (24 - 8 * i));
  };
  put32(16, 16000);
  put32(20, 8000);
  uint32_t crc = 0xffffffffu;  // CRC-32 of "IHDR" and its 13 bytes (PNG specification, annex D)
  for (size_t i = 12; i < 12 + 17; ++i) {
    crc ^= huge[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  put32(29, crc ^ 0xffffffffu);
  EXPECT_FALSE(DecodePngFast(huge, PngWant::kRgb8, &px));
  put32(16, 64);  // the true size again: the patched CRC code is right
  put32(20, 48);
  crc = 0xffffffffu;
  for (size_t i = 12; i < 12 + 17; ++i) {
    crc ^= huge[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  put32(29, crc ^ 0xffffffffu);
  EXPECT_TRUE(DecodePngFast(huge, PngWant::kRgb8, &px));
  // Cut short, empty, not a PNG at all.
  EXPECT_FALSE(DecodePngFast(std::vector<uint8_t>(good.begin(), good.begin() + good.size() / 3), PngWant::kRgb8, &px));
  EXPECT_FALSE(DecodePngFast({}, PngWant::kRgb8, &px));
  // JPEG: OpenCV's path, same pixels as imread.
  const std::string jpeg = dir + "/frame.jpg";
  ASSERT_TRUE(cv::imwrite(jpeg, image));
  EXPECT_FALSE(DecodePngFast(Bytes(jpeg), PngWant::kRgb8, &px));
  const ImageU8 rgb = ReadRgb8(jpeg);
  const cv::Mat expected = OpenCvRgb(jpeg);
  EXPECT_EQ(std::memcmp(rgb.data(), expected.data, expected.total() * 3), 0);
  // An 8-bit file asked for as depth: OpenCV's error naming the file.
  try {
    ReadDepth16(path);
    ADD_FAILURE() << "an 8-bit colour PNG was read as depth";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("16-bit"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dypho
