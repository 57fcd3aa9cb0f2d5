#include "engine/io/png_decode.h"

#include <libdeflate.h>

#include <cstdlib>
#include <cstring>
#include <memory>

namespace dypho {
namespace {

uint32_t Be32(const uint8_t* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

bool ChunkIs(const uint8_t* type, const char* name) { return std::memcmp(type, name, 4) == 0; }

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

// The Paeth predictor (PNG specification, 9.4).
inline int Paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

// Undoes a row's filter in place; `prior` is the unfiltered row above (zeros
// for the first); B bytes per pixel, n a multiple of B. The bytes to the left
// are kept in registers: through memory every byte waited for the store of
// the one B before it (the Sub filter of a depth frame ran at 1 byte per
// 5 cycles). False for an unknown filter type.
template <int B>
bool UnfilterRow(int type, uint8_t* row, const uint8_t* prior, size_t n) {
  uint8_t left[B] = {}, up_left[B] = {};
  switch (type) {
    case 0:
      return true;
    case 1:
      for (size_t i = 0; i < n; i += B)
        for (int k = 0; k < B; ++k) left[k] = row[i + k] = static_cast<uint8_t>(row[i + k] + left[k]);
      return true;
    case 2:
      for (size_t i = 0; i < n; ++i) row[i] = static_cast<uint8_t>(row[i] + prior[i]);
      return true;
    case 3:
      for (size_t i = 0; i < n; i += B)
        for (int k = 0; k < B; ++k)
          left[k] = row[i + k] = static_cast<uint8_t>(row[i + k] + ((left[k] + prior[i + k]) >> 1));
      return true;
    case 4:
      // Paeth(0, b, 0) = b: the first pixel needs no case of its own.
      for (size_t i = 0; i < n; i += B) {
        for (int k = 0; k < B; ++k) {
          const uint8_t up = prior[i + k];
          left[k] = row[i + k] = static_cast<uint8_t>(row[i + k] + Paeth(left[k], up, up_left[k]));
          up_left[k] = up;
        }
      }
      return true;
    default:
      return false;
  }
}

bool Unfilter(int type, uint8_t* row, const uint8_t* prior, size_t n, size_t bpp) {
  switch (bpp) {
    case 1:
      return UnfilterRow<1>(type, row, prior, n);
    case 2:
      return UnfilterRow<2>(type, row, prior, n);
    case 3:
      return UnfilterRow<3>(type, row, prior, n);
    case 4:
      return UnfilterRow<4>(type, row, prior, n);
    default:
      return false;
  }
}

// DecodePngFast with the caller's buffers for the IDAT data and the
// inflated rows.
bool Decode(const std::vector<uint8_t>& file, PngWant want, PngPixels* out, std::vector<uint8_t>& stream,
            std::vector<uint8_t>& raw) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (file.size() < 8 || std::memcmp(file.data(), kSignature, 8) != 0) return false;
  uint32_t width = 0, height = 0;
  int bit_depth = 0, colour_type = -1;
  bool ended = false;
  stream.clear();  // the IDAT chunks' data, concatenated
  size_t pos = 8;
  while (pos + 12 <= file.size()) {
    const uint8_t* p = file.data() + pos;
    const uint32_t length = Be32(p);
    if (length > file.size() - pos - 12) return false;
    const uint8_t* type = p + 4;
    const uint8_t* data = p + 8;
    const bool critical = (type[0] & 0x20) == 0;
    // libpng stops at a bad CRC of a critical chunk; ancillary ones are
    // skipped. (The fuzz target skips the check to reach the data.)
#ifndef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
    if (critical && libdeflate_crc32(0, type, 4 + static_cast<size_t>(length)) != Be32(data + length)) return false;
#endif
    if (ChunkIs(type, "IHDR")) {
      if (length != 13 || colour_type >= 0) return false;
      width = Be32(data);
      height = Be32(data + 4);
      bit_depth = data[8];
      colour_type = data[9];
      // compression 0, filter method 0, no interlacing
      if (data[10] != 0 || data[11] != 0 || data[12] != 0) return false;
    } else if (ChunkIs(type, "IDAT")) {
      if (colour_type < 0) return false;
      stream.insert(stream.end(), data, data + length);
    } else if (ChunkIs(type, "IEND")) {
      ended = true;
      break;
    } else if (ChunkIs(type, "tRNS")) {
      return false;  // transparency: OpenCV may add an alpha channel
    } else if (critical && !ChunkIs(type, "PLTE")) {
      return false;  // unknown critical chunk (a PLTE of a truecolour file is only a suggestion)
    }
    pos += 12 + static_cast<size_t>(length);
  }
  if (!ended || stream.empty() || width == 0 || height == 0 || width > 65536 || height > 65536) return false;

  int channels = 0;  // in the file
  if (want == PngWant::kRgb8 && bit_depth == 8 && (colour_type == 0 || colour_type == 2 || colour_type == 6)) {
    channels = colour_type == 0 ? 1 : colour_type == 2 ? 3 : 4;
  } else if (want == PngWant::kGray8 && bit_depth == 8 && colour_type == 0) {
    channels = 1;
  } else if (want == PngWant::kGray16 && bit_depth == 16 && colour_type == 0) {
    channels = 1;
  } else {
    return false;
  }
  const size_t bpp = static_cast<size_t>(channels) * (bit_depth / 8);
  const size_t row_bytes = bpp * width;
  const size_t raw_size = (row_bytes + 1) * height;
  // Deflate expands at most about 1032:1: a small file claiming a huge image
  // is not decoded (nor its buffer allocated) here.
  if (static_cast<uint64_t>(width) * height > (uint64_t{1} << 27) || raw_size / 1032 > stream.size() + 64)
    return false;
  raw.resize(raw_size);
  thread_local std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> decompressor(
      libdeflate_alloc_decompressor());
  if (!decompressor) return false;
  size_t produced = 0;
  if (libdeflate_zlib_decompress(decompressor.get(), stream.data(), stream.size(), raw.data(), raw.size(),
                                 &produced) != LIBDEFLATE_SUCCESS ||
      produced != raw_size)
    return false;

  // Unfilter in place: row y's bytes start at raw[y * (row_bytes + 1) + 1].
  const std::vector<uint8_t> zeros(row_bytes, 0);
  const uint8_t* prior = zeros.data();
  for (uint32_t y = 0; y < height; ++y) {
    uint8_t* row = raw.data() + y * (row_bytes + 1);
    if (!Unfilter(row[0], row + 1, prior, row_bytes, bpp)) return false;
    prior = row + 1;
  }

  out->width = static_cast<int>(width);
  out->height = static_cast<int>(height);
  out->bytes8.clear();
  out->bytes16.clear();
  const size_t pixels = static_cast<size_t>(width) * height;
  if (want == PngWant::kGray16) {
    out->channels = 1;
    out->bytes16.resize(pixels);
    for (uint32_t y = 0; y < height; ++y) {
      const uint8_t* row = raw.data() + y * (row_bytes + 1) + 1;
      uint16_t* dst = out->bytes16.data() + static_cast<size_t>(y) * width;
      for (uint32_t x = 0; x < width; ++x) dst[x] = static_cast<uint16_t>((row[2 * x] << 8) | row[2 * x + 1]);
    }
    return true;
  }
  const int out_channels = want == PngWant::kRgb8 ? 3 : 1;
  out->channels = out_channels;
  out->bytes8.resize(pixels * out_channels);
  for (uint32_t y = 0; y < height; ++y) {
    const uint8_t* row = raw.data() + y * (row_bytes + 1) + 1;
    uint8_t* dst = out->bytes8.data() + static_cast<size_t>(y) * width * out_channels;
    if (channels == out_channels) {
      std::memcpy(dst, row, row_bytes);
    } else if (channels == 1) {  // grey to RGB
      for (uint32_t x = 0; x < width; ++x) dst[3 * x] = dst[3 * x + 1] = dst[3 * x + 2] = row[x];
    } else {  // RGBA: alpha dropped
      for (uint32_t x = 0; x < width; ++x) std::memcpy(dst + 3 * x, row + 4 * x, 3);
    }
  }
  return true;
}

}  // namespace

bool DecodePngFast(const std::vector<uint8_t>& file, PngWant want, PngPixels* out) {
  // Buffers kept per thread (fresh pages cost as much as the decoding of a
  // frame), given back after an image larger than a few frames.
  thread_local std::vector<uint8_t> stream, raw;
  const bool decoded = Decode(file, want, out, stream, raw);
  constexpr size_t kKeep = size_t{16} << 20;
  if (stream.capacity() > kKeep) std::vector<uint8_t>().swap(stream);
  if (raw.capacity() > kKeep) std::vector<uint8_t>().swap(raw);
  return decoded;
}

}  // namespace dypho
