// Reading and writing images (PNG, JPEG) as common Image types. Errors name
// the file. Writes are atomic.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/image.h"

namespace dypho {

// The largest PNG the readers decode: checked in the file's header first.
constexpr uint64_t kMaxImageSide = 32768;          // [px] per side (the rasterizer's limit)
constexpr uint64_t kMaxImagePixels = 1ull << 27;   // [px] 134 M (e.g. 16384 x 8192)

// 8-bit colour image as RGB (3 channels), converted from whatever the file has.
ImageU8 ReadRgb8(const std::string& path);
// 16-bit single-channel image (e.g. TUM depth). Throws when the file is not
// 16-bit single channel, naming the file and what it found.
Image<uint16_t> ReadDepth16(const std::string& path);
// 8-bit single channel (masks); colour files are converted to grey.
ImageU8 ReadGray8(const std::string& path);
// The same from an image file's bytes already in memory; `name` stands for
// the file in errors.
ImageU8 DecodeRgb8(const std::vector<uint8_t>& bytes, const std::string& name);
Image<uint16_t> DecodeDepth16(const std::vector<uint8_t>& bytes, const std::string& name);
ImageU8 DecodeGray8(const std::vector<uint8_t>& bytes, const std::string& name);

void WriteRgb8(const std::string& path, const ImageU8& rgb);
void WriteGray8(const std::string& path, const ImageU8& gray);
void WriteDepth16(const std::string& path, const Image<uint16_t>& depth);

// Float RGB in [0,1] -> 8-bit (clamped, rounded).
ImageU8 ToRgb8(const ImageF& rgb);
// 8-bit -> float in [0,1].
ImageF ToFloat(const ImageU8& image);
// Metric depth [m] -> 16-bit with `factor` units per metre (0 stays 0).
Image<uint16_t> DepthToU16(const ImageF& depth_m, double factor);
// 16-bit -> metric depth [m] (0 = invalid).
ImageF DepthFromU16(const Image<uint16_t>& depth, double factor);

}  // namespace dypho
