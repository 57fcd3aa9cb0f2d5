// A PNG decoder for the kinds dataset frames come in: 8-bit grey, RGB and
// RGBA and 16-bit grey, not interlaced (the PNG specification, W3C 2003:
// chunks, zlib stream, per-row filters). The zlib stream is inflated by
// libdeflate, about 2-3x faster than the zlib inside OpenCV's libpng: a TUM
// colour frame took 7.9 ms with cv::imread and a depth frame 4.7 ms, most of
// it zlib (measured; BENCHMARKS "PNG decoding"). Anything else (palette,
// interlacing, other bit depths, damaged data) is left to the caller, which
// falls back to OpenCV: the pixels and the errors are OpenCV's there, and the
// same as OpenCV's here (tests/png_decode_test.cc compares every frame).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dypho {

// What the caller wants, as cv::imread's flags would give it.
enum class PngWant {
  kRgb8,     // 3 channels R, G, B (grey replicated, alpha dropped)
  kGray8,    // 1 channel, from 8-bit grey files only
  kGray16,   // 1 channel 16-bit (host order), from 16-bit grey files only
};

struct PngPixels {
  int width = 0, height = 0, channels = 0;
  std::vector<uint8_t> bytes8;    // kRgb8, kGray8: row-major, channels interleaved
  std::vector<uint16_t> bytes16;  // kGray16
};

// Decodes the PNG file held in `file` into `out` when it is a kind handled
// here and decodes cleanly (CRCs, zlib stream, sizes, filters); otherwise
// returns false and `out` is unspecified. Never throws for the file's content.
bool DecodePngFast(const std::vector<uint8_t>& file, PngWant want, PngPixels* out);

}  // namespace dypho
