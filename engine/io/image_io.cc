#include "engine/io/image_io.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/files.h"
#include "engine/io/png_decode.h"

namespace dypho {
namespace {

// The whole file, for the decoders. Names the file when it cannot be read.
std::vector<uint8_t> ReadImageFile(const std::string& path) {
  DYPHO_CHECK_INPUT(std::filesystem::exists(path)) << "image file does not exist: " << path;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  DYPHO_CHECK_INPUT(f != nullptr) << "image file cannot be opened: " << path;
  std::vector<uint8_t> bytes;
  uint8_t buffer[1 << 16];
  size_t got = 0;
  while ((got = std::fread(buffer, 1, sizeof(buffer), f)) > 0) bytes.insert(bytes.end(), buffer, buffer + got);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  DYPHO_CHECK_INPUT(!failed) << "image file cannot be read: " << path;
  return bytes;
}

// A PNG's size from its IHDR chunk (bytes 16..23, big-endian), read before
// anything is decoded: a 30000x30000 image took 32 s and gigabytes to decode
// only to be refused for its size afterwards.
void CheckPngHeader(const std::vector<uint8_t>& h, const std::string& path) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (h.size() < 8 || std::memcmp(h.data(), kSignature, 8) != 0) return;  // not a PNG: OpenCV decides
  DYPHO_CHECK_INPUT(h.size() >= 24 && std::memcmp(h.data() + 12, "IHDR", 4) == 0)
      << "image file does not decode: " << path << " (PNG without an IHDR header)";
  auto be32 = [&](int o) {
    return (uint32_t(h[o]) << 24) | (uint32_t(h[o + 1]) << 16) | (uint32_t(h[o + 2]) << 8) | h[o + 3];
  };
  const uint64_t width = be32(16), height = be32(20);
  DYPHO_CHECK_INPUT(width > 0 && height > 0 && width <= kMaxImageSide && height <= kMaxImageSide &&
                    width * height <= kMaxImagePixels)
      << "image file " << path << " is " << width << "x" << height << " pixels: larger than dypho reads (at most "
      << kMaxImageSide << " on a side and " << kMaxImagePixels << " pixels); not decoded";
}

// PNG kinds of dataset frames: decoded here (engine/io/png_decode.h); else
// (other PNGs, JPEG, ...) OpenCV decodes `bytes` with `flags`.
bool DecodeFast(const std::vector<uint8_t>& bytes, const std::string& path, PngWant want, PngPixels* out) {
  CheckPngHeader(bytes, path);
  return DecodePngFast(bytes, want, out);
}

cv::Mat DecodeWithOpenCv(const std::vector<uint8_t>& bytes, const std::string& path, int flags) {
  cv::Mat m = bytes.empty() ? cv::Mat() : cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1,
                                                               const_cast<uint8_t*>(bytes.data())),
                                                       flags);
  DYPHO_CHECK_INPUT(!m.empty()) << "image file does not decode: " << path;
  return m;
}

template <typename T>
Image<T> FromMat(const cv::Mat& m) {
  Image<T> out(m.cols, m.rows, m.channels());
  for (int y = 0; y < m.rows; ++y) {
    std::memcpy(out.data() + static_cast<size_t>(y) * m.cols * m.channels(), m.ptr(y),
                sizeof(T) * m.cols * m.channels());
  }
  return out;
}

template <typename T>
cv::Mat ToMat(const Image<T>& image, int type) {
  cv::Mat m(image.height(), image.width(), type);
  for (int y = 0; y < image.height(); ++y) {
    std::memcpy(m.ptr(y), image.data() + static_cast<size_t>(y) * image.width() * image.channels(),
                sizeof(T) * image.width() * image.channels());
  }
  return m;
}

void WriteMat(const std::string& path, const cv::Mat& m) {
  const std::string ext = std::filesystem::path(path).extension().string();
  WriteFileAtomically(path, [&](const std::string& tmp) {
    std::vector<uchar> bytes;
    DYPHO_CHECK_INPUT(cv::imencode(ext.empty() ? ".png" : ext, m, bytes))
        << "cannot encode image for " << path;
    FILE* f = std::fopen(tmp.c_str(), "wb");
    DYPHO_CHECK_INPUT(f != nullptr) << "cannot open " << tmp << " for writing";
    const size_t written = std::fwrite(bytes.data(), 1, bytes.size(), f);
    const bool ok = std::fclose(f) == 0 && written == bytes.size();
    DYPHO_CHECK_INPUT(ok) << "error writing " << path;
  });
}

}  // namespace

ImageU8 DecodeRgb8(const std::vector<uint8_t>& bytes, const std::string& name) {
  PngPixels px;
  if (DecodeFast(bytes, name, PngWant::kRgb8, &px)) return ImageU8(px.width, px.height, 3, std::move(px.bytes8));
  cv::Mat m = DecodeWithOpenCv(bytes, name, cv::IMREAD_COLOR);
  cv::Mat rgb;
  cv::cvtColor(m, rgb, cv::COLOR_BGR2RGB);
  return FromMat<uint8_t>(rgb);
}

Image<uint16_t> DecodeDepth16(const std::vector<uint8_t>& bytes, const std::string& name) {
  PngPixels px;
  if (DecodeFast(bytes, name, PngWant::kGray16, &px))
    return Image<uint16_t>(px.width, px.height, 1, std::move(px.bytes16));
  cv::Mat m = DecodeWithOpenCv(bytes, name, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  DYPHO_CHECK_INPUT(m.depth() == CV_16U && m.channels() == 1)
      << "depth image " << name << " must be 16-bit single channel (found "
      << (m.depth() == CV_8U ? "8-bit" : "type " + std::to_string(m.depth())) << ", "
      << m.channels() << " channel(s))";
  return FromMat<uint16_t>(m);
}

ImageU8 DecodeGray8(const std::vector<uint8_t>& bytes, const std::string& name) {
  PngPixels px;
  if (DecodeFast(bytes, name, PngWant::kGray8, &px)) return ImageU8(px.width, px.height, 1, std::move(px.bytes8));
  cv::Mat m = DecodeWithOpenCv(bytes, name, cv::IMREAD_GRAYSCALE);
  return FromMat<uint8_t>(m);
}

ImageU8 ReadRgb8(const std::string& path) { return DecodeRgb8(ReadImageFile(path), path); }
Image<uint16_t> ReadDepth16(const std::string& path) { return DecodeDepth16(ReadImageFile(path), path); }
ImageU8 ReadGray8(const std::string& path) { return DecodeGray8(ReadImageFile(path), path); }

void WriteRgb8(const std::string& path, const ImageU8& rgb) {
  DYPHO_CHECK_INPUT(rgb.channels() == 3 && !rgb.empty()) << "WriteRgb8 " << path << ": need a non-empty 3-channel image";
  cv::Mat bgr;
  cv::cvtColor(ToMat(rgb, CV_8UC3), bgr, cv::COLOR_RGB2BGR);
  WriteMat(path, bgr);
}

void WriteGray8(const std::string& path, const ImageU8& gray) {
  DYPHO_CHECK_INPUT(gray.channels() == 1 && !gray.empty()) << "WriteGray8 " << path << ": need a non-empty 1-channel image";
  WriteMat(path, ToMat(gray, CV_8UC1));
}

void WriteDepth16(const std::string& path, const Image<uint16_t>& depth) {
  DYPHO_CHECK_INPUT(depth.channels() == 1 && !depth.empty()) << "WriteDepth16 " << path << ": need a non-empty 1-channel image";
  WriteMat(path, ToMat(depth, CV_16UC1));
}

ImageU8 ToRgb8(const ImageF& rgb) {
  ImageU8 out(rgb.width(), rgb.height(), rgb.channels());
  for (size_t i = 0; i < rgb.size(); ++i) {
    float v = rgb.data()[i];
    v = std::isfinite(v) ? std::min(1.0f, std::max(0.0f, v)) : 0.0f;
    out.data()[i] = static_cast<uint8_t>(std::lround(v * 255.0f));
  }
  return out;
}

ImageF ToFloat(const ImageU8& image) {
  ImageF out(image.width(), image.height(), image.channels());
  for (size_t i = 0; i < image.size(); ++i) out.data()[i] = image.data()[i] / 255.0f;
  return out;
}

Image<uint16_t> DepthToU16(const ImageF& depth_m, double factor) {
  Image<uint16_t> out(depth_m.width(), depth_m.height(), 1);
  for (size_t i = 0; i < depth_m.size(); ++i) {
    const double v = depth_m.data()[i] * factor;
    out.data()[i] = (std::isfinite(v) && v > 0) ? static_cast<uint16_t>(std::min(65535.0, std::round(v))) : 0;
  }
  return out;
}

ImageF DepthFromU16(const Image<uint16_t>& depth, double factor) {
  ImageF out(depth.width(), depth.height(), 1);
  for (size_t i = 0; i < depth.size(); ++i) out.data()[i] = static_cast<float>(depth.data()[i] / factor);
  return out;
}

}  // namespace dypho
