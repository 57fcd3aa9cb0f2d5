// A PNG encoder for the images the engine keeps packed (keyframe_store.h):
// 8-bit grey, 8-bit RGB and 16-bit grey, every row with the Sub filter and
// the zlib stream made by libdeflate at level 1 (the PNG specification,
// W3C 2003). On TUM colour + depth frames it takes 8.4 ms against 24 ms for
// cv::imencode at PNG level 1 (zlib, per-row filter choice), for the same
// size within 3 % (BENCHMARKS, issue 20). The files are ordinary PNGs:
// png_decode.h and OpenCV read them.
#pragma once

#include <cstdint>
#include <vector>

namespace dypho {

// `pixels`: rows of width * channels samples, packed, host order.
// channels 1 or 3 for 8-bit, 1 for 16-bit. Throws InvalidInput on other shapes.
std::vector<uint8_t> EncodePng8(const uint8_t* pixels, int width, int height, int channels);
std::vector<uint8_t> EncodePng16(const uint16_t* pixels, int width, int height);

}  // namespace dypho
