#include "engine/map/image_sharpness.h"

#include <algorithm>
#include <cmath>

namespace dypho {
namespace sharpness_steps {
namespace {

// One source pixel's share of a destination pixel along one axis.
struct AreaTap {
  int src;      // source index
  int dst;      // destination index
  float alpha;  // weight (the shares of one destination sum to 1)
};

// The taps of an area reduction from `src_size` to `dst_size` pixels, in
// destination order: each destination covers `scale` = src / dst source
// pixels; partly covered source pixels at either end get their covered
// fraction (ignored below 1e-3 of a pixel).
std::vector<AreaTap> AreaTaps(int src_size, int dst_size) {
  const double scale = 1.0 / (static_cast<double>(dst_size) / src_size);
  std::vector<AreaTap> taps;
  for (int d = 0; d < dst_size; ++d) {
    const double begin = d * scale, end = begin + scale;
    const double cell = std::min(scale, src_size - begin);
    int first = static_cast<int>(std::ceil(begin)), last = static_cast<int>(std::floor(end));
    last = std::min(last, src_size - 1);
    first = std::min(first, last);
    if (first - begin > 1e-3) taps.push_back({first - 1, d, static_cast<float>((first - begin) / cell)});
    for (int s = first; s < last; ++s) taps.push_back({s, d, static_cast<float>(1.0 / cell)});
    if (end - last > 1e-3) {
      taps.push_back({last, d, static_cast<float>(std::min(std::min(end - last, 1.0), cell) / cell)});
    }
  }
  return taps;
}

uint8_t RoundToU8(float v) {
  const long r = std::lrint(v);  // to nearest, ties to even
  return static_cast<uint8_t>(std::clamp<long>(r, 0, 255));
}

// Reflection without repeating the edge: -1 -> 1, n -> n - 2.
int Reflect101(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * (n - 1) - i;
  return i;
}

}  // namespace

ImageU8 Grey(const ImageU8& rgb) {
  ImageU8 grey(rgb.width(), rgb.height(), 1);
  const int c = rgb.channels();
  const uint8_t* src = rgb.data();
  uint8_t* dst = grey.data();
  for (size_t i = 0; i < grey.size(); ++i, src += c) {
    if (c == 3) {
      dst[i] = static_cast<uint8_t>((9798u * src[0] + 19235u * src[1] + 3735u * src[2] + (1u << 14)) >> 15);
    } else {
      dst[i] = src[0];  // other channel counts: the first channel
    }
  }
  return grey;
}

ImageU8 HalfArea(const ImageU8& grey) {
  const int w = grey.width(), h = grey.height(), dw = w / 2, dh = h / 2;
  ImageU8 half(dw, dh, 1);
  if (dw == 0 || dh == 0) return half;
  if (w == 2 * dw && h == 2 * dh) {
    // An exact halving: the mean of each 2x2 block, rounded half up.
    for (int y = 0; y < dh; ++y) {
      const uint8_t* r0 = grey.data() + static_cast<size_t>(2 * y) * w;
      const uint8_t* r1 = r0 + w;
      for (int x = 0; x < dw; ++x) {
        half.at(x, y) = static_cast<uint8_t>((r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1] + 2) >> 2);
      }
    }
    return half;
  }
  // Area weights in float: each source row is reduced along x, then the rows
  // of one destination row are summed with their y weights.
  const std::vector<AreaTap> xtaps = AreaTaps(w, dw), ytaps = AreaTaps(h, dh);
  std::vector<float> row(dw), sum(dw, 0.0f);
  int current = ytaps.front().dst;
  for (const AreaTap& yt : ytaps) {
    std::fill(row.begin(), row.end(), 0.0f);
    const uint8_t* src = grey.data() + static_cast<size_t>(yt.src) * w;
    for (const AreaTap& xt : xtaps) row[xt.dst] += src[xt.src] * xt.alpha;
    if (yt.dst != current) {
      for (int x = 0; x < dw; ++x) {
        half.at(x, current) = RoundToU8(sum[x]);
        sum[x] = yt.alpha * row[x];
      }
      current = yt.dst;
    } else {
      for (int x = 0; x < dw; ++x) sum[x] += yt.alpha * row[x];
    }
  }
  for (int x = 0; x < dw; ++x) half.at(x, current) = RoundToU8(sum[x]);
  return half;
}

ImageU8 HalfGreyOfRgb(const ImageU8& rgb) {
  const int w = rgb.width(), dw = w / 2, dh = rgb.height() / 2;
  ImageU8 half(dw, dh, 1);
  auto grey = [](const uint8_t* p) {
    return (9798u * p[0] + 19235u * p[1] + 3735u * p[2] + (1u << 14)) >> 15;
  };
  for (int y = 0; y < dh; ++y) {
    const uint8_t* r0 = rgb.data() + static_cast<size_t>(2 * y) * w * 3;
    const uint8_t* r1 = r0 + static_cast<size_t>(w) * 3;
    uint8_t* out = half.data() + static_cast<size_t>(y) * dw;
    for (int x = 0; x < dw; ++x) {
      const unsigned sum = grey(r0 + 6 * x) + grey(r0 + 6 * x + 3) + grey(r1 + 6 * x) + grey(r1 + 6 * x + 3);
      out[x] = static_cast<uint8_t>((sum + 2) >> 2);
    }
  }
  return half;
}

ImageF Laplacian(const ImageU8& grey) {
  const int w = grey.width(), h = grey.height();
  ImageF lap(w, h, 1);
  for (int y = 0; y < h; ++y) {
    const uint8_t* row = grey.data() + static_cast<size_t>(y) * w;
    const uint8_t* up = grey.data() + static_cast<size_t>(Reflect101(y - 1, h)) * w;
    const uint8_t* down = grey.data() + static_cast<size_t>(Reflect101(y + 1, h)) * w;
    float* out = lap.data() + static_cast<size_t>(y) * w;
    auto at = [&](int x, int left, int right) {
      out[x] = static_cast<float>(up[x] + row[left] + row[right] + down[x] - 4 * row[x]);
    };
    if (w == 1) {
      at(0, 0, 0);
      continue;
    }
    at(0, Reflect101(-1, w), 1);
    for (int x = 1; x + 1 < w; ++x) at(x, x - 1, x + 1);
    at(w - 1, w - 2, Reflect101(w, w));
  }
  return lap;
}

ImageU8 StaticMask(const ImageU8& dynamic_mask, int width, int height) {
  // Nearest neighbour: destination x reads source floor(x * src / dst).
  const int sw = dynamic_mask.width(), sh = dynamic_mask.height();
  const double ifx = 1.0 / (static_cast<double>(width) / sw), ify = 1.0 / (static_cast<double>(height) / sh);
  ImageU8 small(width, height, 1);
  for (int y = 0; y < height; ++y) {
    const int sy = std::min(static_cast<int>(std::floor(y * ify)), sh - 1);
    for (int x = 0; x < width; ++x) {
      const int sx = std::min(static_cast<int>(std::floor(x * ifx)), sw - 1);
      small.at(x, y) = dynamic_mask.at(sx, sy) == 0 ? 255 : 0;
    }
  }
  // Erosion by a 5x5 square; outside the image does not erode. A square's
  // minimum is the minimum over its rows of the minimum along each row, so
  // it runs as a 5-pixel pass along x, then one along y.
  ImageU8 rows(width, height, 1), eroded(width, height, 1);
  for (int y = 0; y < height; ++y) {
    const uint8_t* src = small.data() + static_cast<size_t>(y) * width;
    uint8_t* dst = rows.data() + static_cast<size_t>(y) * width;
    for (int x = 0; x < width; ++x) {
      uint8_t v = 255;
      for (int xx = std::max(0, x - 2); xx <= std::min(width - 1, x + 2); ++xx) v = std::min(v, src[xx]);
      dst[x] = v;
    }
  }
  for (int y = 0; y < height; ++y) {
    uint8_t* dst = eroded.data() + static_cast<size_t>(y) * width;
    std::fill(dst, dst + width, static_cast<uint8_t>(255));
    for (int yy = std::max(0, y - 2); yy <= std::min(height - 1, y + 2); ++yy) {
      const uint8_t* src = rows.data() + static_cast<size_t>(yy) * width;
      for (int x = 0; x < width; ++x) dst[x] = std::min(dst[x], src[x]);
    }
  }
  return eroded;
}

}  // namespace sharpness_steps

double ImageSharpness(const ImageU8& rgb, const ImageU8& dynamic_mask) {
  using namespace sharpness_steps;
  if (rgb.empty()) return 0.0;
  // RGB of even size (every camera here): grey and the exact halving in one
  // pass, the same integers as the two steps (no full-size grey image).
  const ImageU8 half = rgb.channels() == 3 && rgb.width() % 2 == 0 && rgb.height() % 2 == 0
                           ? HalfGreyOfRgb(rgb)
                           : HalfArea(Grey(rgb));
  if (half.empty()) return 0.0;
  const ImageF lap = Laplacian(half);
  ImageU8 mask;
  if (!dynamic_mask.empty()) {
    mask = StaticMask(dynamic_mask, half.width(), half.height());
    const auto count = std::count_if(mask.pixels().begin(), mask.pixels().end(), [](uint8_t v) { return v != 0; });
    if (count < 100) return 0.0;
  }
  double sum = 0.0, sum_sq = 0.0;
  int64_t n = 0;
  for (size_t i = 0; i < lap.size(); ++i) {
    if (!mask.empty() && mask.data()[i] == 0) continue;
    const double v = lap.data()[i];
    sum += v;
    sum_sq += v * v;
    ++n;
  }
  // As a standard deviation first, then squared (the formulation it
  // replaced: equal to the last bit).
  const double scale = n ? 1.0 / n : 0.0;
  const double mean = sum * scale;
  const double stddev = std::sqrt(std::max(sum_sq * scale - mean * mean, 0.0));
  return stddev * stddev;
}

}  // namespace dypho
