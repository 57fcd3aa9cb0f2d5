// ELAS stage 1: per-pixel descriptors from Sobel responses, and their L1 distance.
#pragma once

#include <cstdint>
#include <cstdlib>

#include <opencv2/core.hpp>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace dypho::stereo {

constexpr int kDescriptorBytes = 16;

// Descriptors of an 8-bit grey image: CV_8UC(16), one 16-byte vector a pixel.
// Bytes 0-10: horizontal Sobel (3x3) at the 3x3 block around the pixel and at
// (x-2, y), (x+2, y); bytes 11-15: vertical Sobel at the pixel and its 4-neighbours.
// Each response r is stored as saturate(128 + r / 4). Borders are replicated.
cv::Mat ComputeDescriptors(const cv::Mat& grey);

// Texture of each descriptor: sum over bytes of |f - 128|, CV_16U.
cv::Mat DescriptorTexture(const cv::Mat& descriptors);

// L1 distance of two 16-byte descriptors.
inline int DescriptorDistance(const uint8_t* a, const uint8_t* b) {
#if defined(__SSE2__)
  const __m128i va = _mm_loadu_si128(reinterpret_cast<const __m128i*>(a));
  const __m128i vb = _mm_loadu_si128(reinterpret_cast<const __m128i*>(b));
  const __m128i sad = _mm_sad_epu8(va, vb);
  return _mm_cvtsi128_si32(sad) + _mm_extract_epi16(sad, 4);
#else
  int sum = 0;
  for (int i = 0; i < kDescriptorBytes; ++i) sum += std::abs(int(a[i]) - int(b[i]));
  return sum;
#endif
}

}  // namespace dypho::stereo
