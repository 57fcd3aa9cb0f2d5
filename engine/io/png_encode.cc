#include "engine/io/png_encode.h"

#include <libdeflate.h>

#include <cstring>
#include <memory>

#include "common/check.h"

namespace dypho {
namespace {

void PutBe32(std::vector<uint8_t>* out, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out->push_back(static_cast<uint8_t>(v >> s));
}

void PutChunk(std::vector<uint8_t>* out, const char type[4], const uint8_t* data, size_t size) {
  PutBe32(out, static_cast<uint32_t>(size));
  const size_t start = out->size();
  out->insert(out->end(), type, type + 4);
  if (size) out->insert(out->end(), data, data + size);
  PutBe32(out, libdeflate_crc32(0, out->data() + start, 4 + size));
}

// `rows`: height rows of `row_bytes` bytes each, PNG byte order; `bpp`: bytes per pixel.
std::vector<uint8_t> Encode(const uint8_t* rows, int width, int height, int bit_depth, int colour_type, int bpp) {
  DYPHO_CHECK_INPUT(width > 0 && height > 0) << "EncodePng: empty image";
  const size_t row_bytes = static_cast<size_t>(width) * bpp;
  // Every row with filter 1 (Sub): each byte minus the byte one pixel to its left.
  std::vector<uint8_t> filtered((row_bytes + 1) * height);
  for (int y = 0; y < height; ++y) {
    uint8_t* o = filtered.data() + y * (row_bytes + 1);
    const uint8_t* r = rows + y * row_bytes;
    o[0] = 1;
    std::memcpy(o + 1, r, static_cast<size_t>(bpp));
    for (size_t i = bpp; i < row_bytes; ++i) o[1 + i] = static_cast<uint8_t>(r[i] - r[i - bpp]);
  }
  std::unique_ptr<libdeflate_compressor, decltype(&libdeflate_free_compressor)> c(libdeflate_alloc_compressor(1),
                                                                                   &libdeflate_free_compressor);
  DYPHO_CHECK(c != nullptr) << "EncodePng: out of memory";
  std::vector<uint8_t> z(libdeflate_zlib_compress_bound(c.get(), filtered.size()));
  z.resize(libdeflate_zlib_compress(c.get(), filtered.data(), filtered.size(), z.data(), z.size()));
  DYPHO_CHECK(!z.empty()) << "EncodePng: compression failed";

  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<uint8_t> out(kSignature, kSignature + 8);
  out.reserve(z.size() + 64);
  std::vector<uint8_t> ihdr;
  PutBe32(&ihdr, static_cast<uint32_t>(width));
  PutBe32(&ihdr, static_cast<uint32_t>(height));
  ihdr.insert(ihdr.end(), {static_cast<uint8_t>(bit_depth), static_cast<uint8_t>(colour_type), 0, 0, 0});
  PutChunk(&out, "IHDR", ihdr.data(), ihdr.size());
  PutChunk(&out, "IDAT", z.data(), z.size());
  PutChunk(&out, "IEND", nullptr, 0);
  return out;
}

}  // namespace

std::vector<uint8_t> EncodePng8(const uint8_t* pixels, int width, int height, int channels) {
  DYPHO_CHECK_INPUT(channels == 1 || channels == 3) << "EncodePng8: 1 or 3 channels (got " << channels << ")";
  return Encode(pixels, width, height, 8, channels == 1 ? 0 : 2, channels);
}

std::vector<uint8_t> EncodePng16(const uint16_t* pixels, int width, int height) {
  // PNG samples are big-endian.
  std::vector<uint8_t> be(static_cast<size_t>(width) * height * 2);
  for (size_t i = 0; i < be.size() / 2; ++i) {
    be[2 * i] = static_cast<uint8_t>(pixels[i] >> 8);
    be[2 * i + 1] = static_cast<uint8_t>(pixels[i]);
  }
  return Encode(be.data(), width, height, 16, 0, 2);
}

}  // namespace dypho
