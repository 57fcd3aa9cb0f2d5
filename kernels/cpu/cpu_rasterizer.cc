#include "kernels/cpu/cpu_rasterizer.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <type_traits>

#include "common/check.h"
#include "common/files.h"
#include "kernels/cpu/block_pool.h"
#include "kernels/math/preprocess.h"

namespace dypho::kernels::cpu {
namespace {

using math::CameraData;
using math::Projected;
using math::ScreenGrads;
using math::Vec3;

constexpr int kTilePixels = kTileSize * kTileSize;

// What the pixel loops read for one visible Gaussian, stored by rank (its
// place in compositing order), so a walk in that order reads memory in order.
template <typename T>
struct Packed {
  T mean_x, mean_y;     // 2D mean [px]
  T A, B, C;            // conic
  T opacity;
  T power_min;          // the exact per-pixel test: power >= power_min
  T power_min_culling;  // math::CullingPowerMin(power_min): counts evaluations
  T y_ext;              // the enlarged ellipse reaches rows |py - mean_y| <= y_ext
  T x_ext;              // and columns |px - mean_x| <= x_ext
  T color[3];
  T depth;              // camera z [m]
  T oit_f, oit_dfdz;    // order-independent weight f(z) and f'(z)
};

// Tile rows [y0, y1) a Gaussian touches; and, per touched tile row, the tile
// columns [x0, x1] its enlarged ellipse reaches there (x0 > x1: none).
struct TileRows {
  int16_t y0, y1;
};
struct Span {
  int16_t x0, x1;
};
// One entry of a tile row's list: a Gaussian (by rank) and its tile columns.
struct RowEntry {
  int32_t rank;
  int16_t x0, x1;
};

template <typename T>
class CpuState : public RasterState {
 public:
  RasterStats stats() const override { return stats_; }

  RasterStats stats_;
  CompositeMode mode_ = CompositeMode::kSorted;
  CameraData<T> cam_;
  int num_threads_ = 1;
  PoolVector<Projected<T>> projected_;  // [N]
  PoolVector<uint8_t> status_;          // [N] math::ProjectStatus
  PoolVector<int32_t> order_;           // [V] Gaussian id by rank: depth order (sorted mode) or index order
  PoolVector<Packed<T>> packed_;        // [V] by rank
  PoolVector<TileRows> tile_rows_;      // [V] by rank
  PoolVector<int64_t> span_base_;       // [V + 1] first (rank, tile row) pair of each rank
  PoolVector<Span> spans_;              // [E] per (rank, touched tile row), rank-major
  PoolVector<RowEntry> row_list_;       // [E'] per tile row, its Gaussians (non-empty spans) in rank order
  PoolVector<int64_t> row_begin_;       // [tiles_y + 1] each tile row's part of row_list_
  PoolVector<int64_t> row_scan_end_;    // [tiles_y] row_list_ entries below this were walked by the forward
  // Sorted mode, per pixel.
  PoolVector<T> final_transmittance_;  // [H*W]
  PoolVector<int32_t> num_contrib_;    // [H*W] 1 + rank of the last composited Gaussian (0: none)
  PoolVector<T> color_;                // [H*W*3] output colour (with background)
  PoolVector<T> depth_;                // [H*W]
  // Order-independent mode, per pixel.
  PoolVector<T> sum_weight_;    // [H*W] A
  PoolVector<T> prod_transmit_; // [H*W] P
  PoolVector<T> mean_color_;    // [H*W*3] Cbar
  PoolVector<T> mean_depth_;    // [H*W] Dbar
  T background_[3] = {0, 0, 0};
};

// The per-Gaussian chains with every GLM helper inlined (GCC and Clang leave
// some 3x3 products as calls otherwise, a third of the time of these stages).
#if defined(__GNUC__)
#define DYPHO_FLATTEN __attribute__((flatten))
#else
#define DYPHO_FLATTEN
#endif

template <typename T>
DYPHO_FLATTEN int ProjectOne(int i, const GaussianParamsT<T>& params, const CameraData<T>& cam, Projected<T>* out) {
  return math::ProjectGaussian(i, params.means, params.log_scales, params.quats, params.opacity_logits, params.sh,
                               params.sh_coeffs, cam, out);
}

template <typename T>
DYPHO_FLATTEN void ProjectOneVjp(int i, const GaussianParamsT<T>& params, const CameraData<T>& cam, unsigned clamped,
                                 const ScreenGrads<T>& g, T* v_mean, T* v_ls, T* v_q, T* v_logit, T* v_sh,
                                 math::Mat3<T>* v_R, Vec3<T>* v_t) {
  math::ProjectGaussianVjp(i, params.means, params.log_scales, params.quats, params.opacity_logits, params.sh,
                           params.sh_coeffs, cam, clamped, g, v_mean, v_ls, v_q, v_logit, v_sh, v_R, v_t);
}

int ThreadCount(const RasterSettings& settings) {
  return settings.num_threads > 0 ? settings.num_threads : DefaultThreadCount();
}

// The footprint enlarged for culling (math::CullingPowerMin).
template <typename T>
inline math::SplatT<T> Enlarged(const math::SplatT<T>& s) {
  math::SplatT<T> e = s;
  e.power_min = math::CullingPowerMin(s.power_min);
  return e;
}

// Visible Gaussians in depth order, ties by index: a stable LSD radix sort on
// the float depth's bits, mapped so that unsigned order is float order; the
// double instantiation (tests) sorts by comparison.
template <typename T>
void SortByDepth(const PoolVector<Projected<T>>& projected, PoolVector<int32_t>* order) {
  const size_t n = order->size();
  if constexpr (std::is_same_v<T, float>) {
    PoolVector<uint32_t> keys(n), keys2(n);
    PoolVector<int32_t> ids2(n);
    for (size_t i = 0; i < n; ++i) {
      const float z = projected[(*order)[i]].depth + 0.0f;  // -0 -> +0
      uint32_t bits;
      std::memcpy(&bits, &z, sizeof(bits));
      keys[i] = (bits & 0x80000000u) ? ~bits : (bits | 0x80000000u);
    }
    constexpr int kBits = 11, kBuckets = 1 << kBits;
    PoolVector<uint32_t> count(kBuckets);
    for (int shift = 0; shift < 32; shift += kBits) {
      std::fill(count.begin(), count.end(), 0u);
      for (size_t i = 0; i < n; ++i) ++count[(keys[i] >> shift) & (kBuckets - 1)];
      if (count[(keys.empty() ? 0 : keys[0] >> shift) & (kBuckets - 1)] == n) continue;  // one bucket
      uint32_t sum = 0;
      for (uint32_t& c : count) {
        const uint32_t c0 = c;
        c = sum;
        sum += c0;
      }
      for (size_t i = 0; i < n; ++i) {
        const uint32_t dst = count[(keys[i] >> shift) & (kBuckets - 1)]++;
        keys2[dst] = keys[i];
        ids2[dst] = (*order)[i];
      }
      keys.swap(keys2);
      order->swap(ids2);
    }
  } else {
    std::stable_sort(order->begin(), order->end(),
                     [&](int32_t a, int32_t b) { return projected[a].depth < projected[b].depth; });
  }
}

// Widest image in tiles (rasterizer.cc limits images to 32768 pixels).
constexpr int kMaxTilesX = 32768 / kTileSize;

// Ranks are binned into tile rows in fixed chunks (independent of the thread
// count), so each row list comes out in rank order.
constexpr int kRankChunk = 2048;

// ---------------------------------------------------------------------------
// Forward. One thread owns a tile row: it walks the Gaussians touching the
// row in rank order and rasterizes each into the tiles its span reaches, a
// pixel row of 16 at a time. The pixel loops are branch-free (selects) over
// structure-of-arrays tile buffers, so the compiler vectorizes them across a
// pixel row; pixels outside the exact ellipse test contribute exactly nothing,
// so the result equals the per-pixel definition.

template <typename T>
struct SortedTile {
  alignas(64) T trans[kTilePixels];
  alignas(64) T red[kTilePixels];
  alignas(64) T green[kTilePixels];
  alignas(64) T blue[kTilePixels];
  alignas(64) T depth[kTilePixels];
  alignas(64) int32_t last[kTilePixels];  // 1 + rank of the last composited Gaussian
  alignas(64) int32_t done[kTilePixels];  // 1 once terminated (or outside the image)
  int row_active[kTileSize];              // pixels not done, per row
  int active;                             // pixels not done in the tile
};

template <typename T>
struct OitTile {
  alignas(64) T sum_w[kTilePixels];
  alignas(64) T prod[kTilePixels];
  alignas(64) T red[kTilePixels];
  alignas(64) T green[kTilePixels];
  alignas(64) T blue[kTilePixels];
  alignas(64) T depth[kTilePixels];
};

// Tile geometry: pixel origin, last pixel row, number of pixel columns inside the image.
struct TileBox {
  int x0, y0, y1, cols;
};
inline TileBox MakeTileBox(int tx, int ty, int width, int height) {
  TileBox b;
  b.x0 = tx * kTileSize;
  b.y0 = ty * kTileSize;
  b.y1 = std::min(b.y0 + kTileSize, height) - 1;
  b.cols = std::min(kTileSize, width - b.x0);
  return b;
}

// Pixel rows [*py0, *py1] of a tile in which the enlarged footprint reaches
// one of the tile's pixel columns: when the footprint sticks out of the
// columns, math::EllipseBandExtent with x and y swapped (the y-extent of the
// ellipse within the column band), else its whole y-extent.
// The integer range [lo, hi] (already ceil'd or floor'd) clipped to
// [min, max] while still floating point: a NaN or a value beyond int range
// (a camera with its principal point at 1e9, a Gaussian at the near plane)
// must never reach the conversion to int, where it is undefined behaviour
// (on x86 INT_MIN, which then wrapped in the int16 spans and wrote past the
// row lists). Returns false for an empty range.
template <typename T>
inline bool ClippedRange(T lo, T hi, int min, int max, int* a, int* b) {
  if (!(lo <= hi) || hi < T(min) || lo > T(max)) {
    *a = 1;
    *b = 0;
    return false;
  }
  *a = lo < T(min) ? min : static_cast<int>(lo);
  *b = hi > T(max) ? max : static_cast<int>(hi);
  return *a <= *b;
}

template <typename T>
inline void TileRowRange(const Packed<T>& s, TileBox box, int* py0, int* py1) {
  const T x0 = T(box.x0), x1 = T(box.x0 + box.cols - 1);
  T lo = -s.y_ext, hi = s.y_ext;
  if (s.mean_x - s.x_ext < x0 || s.mean_x + s.x_ext > x1) {
    math::SplatT<T> swapped;
    swapped.mean_x = s.mean_y;
    swapped.mean_y = s.mean_x;
    swapped.A = s.C;
    swapped.B = s.B;
    swapped.C = s.A;
    swapped.opacity = s.opacity;
    swapped.power_min = s.power_min_culling;
    if (!math::EllipseBandExtent(swapped, x0 - s.mean_x, x1 - s.mean_x, &lo, &hi)) {
      *py0 = 1;
      *py1 = 0;
      return;
    }
  }
  ClippedRange(std::ceil(s.mean_y + lo), std::floor(s.mean_y + hi), box.y0, box.y1, py0, py1);
}

template <typename T>
void InitSortedTile(SortedTile<T>* t, TileBox box) {
  const int rows = box.y1 - box.y0 + 1;
  for (int i = 0; i < kTilePixels; ++i) {
    t->trans[i] = T(1);
    t->red[i] = t->green[i] = t->blue[i] = t->depth[i] = T(0);
    t->last[i] = 0;
    t->done[i] = (i % kTileSize >= box.cols) | (i / kTileSize >= rows);
  }
  for (int r = 0; r < kTileSize; ++r) t->row_active[r] = r < rows ? box.cols : 0;
  t->active = rows * box.cols;
}

// Composites Gaussian `s` (rank + 1 = rank1) into one tile; returns the
// number of live pixels inside its enlarged footprint (evaluations).
template <typename T>
int RasterizeSorted(SortedTile<T>* t, TileBox box, const Packed<T>& s, int32_t rank1) {
  int py0, py1;
  TileRowRange(s, box, &py0, &py1);
  const T A = s.A, B = s.B, C = s.C, o = s.opacity, pmin = s.power_min, pmin_e = s.power_min_culling;
  const T mx = s.mean_x, my = s.mean_y, c0 = s.color[0], c1 = s.color[1], c2 = s.color[2], z = s.depth;
  const int x0 = box.x0;
  int32_t counted[kTileSize] = {};  // per lane, summed once (no reduction per row)
  for (int py = py0; py <= py1; ++py) {
    const int row = py - box.y0;
    if (t->row_active[row] == 0) continue;
    const T dy = T(py) - my;
    const int b = row * kTileSize;
    T* __restrict trans = t->trans + b;
    T* __restrict red = t->red + b;
    T* __restrict green = t->green + b;
    T* __restrict blue = t->blue + b;
    T* __restrict depth = t->depth + b;
    int32_t* __restrict last = t->last + b;
    int32_t* __restrict done = t->done + b;
    int terminated = 0;
    for (int j = 0; j < kTileSize; ++j) {
      const T dx = T(x0 + j) - mx;
      const T power = math::SplatPower(A, B, C, dx, dy);
      const T alpha = math::SplatAlpha(o, power);
      const T next = trans[j] * (T(1) - alpha);
      const bool live = done[j] == 0;
      const bool valid = (power >= pmin) & live;
      const bool stop = valid & (next < T(math::kMinTransmittance));
      const bool add = valid & !stop;
      const T w = add ? alpha * trans[j] : T(0);
      red[j] += w * c0;
      green[j] += w * c1;
      blue[j] += w * c2;
      depth[j] += w * z;
      trans[j] = add ? next : trans[j];
      last[j] = add ? rank1 : last[j];
      done[j] |= static_cast<int32_t>(stop);
      terminated += stop;
      counted[j] += (power >= pmin_e) & live;
    }
    t->row_active[row] -= terminated;
    t->active -= terminated;
  }
  int evaluations = 0;
  for (int j = 0; j < kTileSize; ++j) evaluations += counted[j];
  return evaluations;
}

template <typename T>
int RasterizeOit(OitTile<T>* t, TileBox box, const Packed<T>& s) {
  int py0, py1;
  TileRowRange(s, box, &py0, &py1);
  const T A = s.A, B = s.B, C = s.C, o = s.opacity, pmin = s.power_min, pmin_e = s.power_min_culling;
  const T mx = s.mean_x, my = s.mean_y, c0 = s.color[0], c1 = s.color[1], c2 = s.color[2], z = s.depth;
  const T f = s.oit_f;
  const int x0 = box.x0, cols = box.cols;
  int32_t counted[kTileSize] = {};
  for (int py = py0; py <= py1; ++py) {
    const T dy = T(py) - my;
    const int b = (py - box.y0) * kTileSize;
    T* __restrict sum_w = t->sum_w + b;
    T* __restrict prod = t->prod + b;
    T* __restrict red = t->red + b;
    T* __restrict green = t->green + b;
    T* __restrict blue = t->blue + b;
    T* __restrict depth = t->depth + b;
    for (int j = 0; j < kTileSize; ++j) {
      const T dx = T(x0 + j) - mx;
      const T power = math::SplatPower(A, B, C, dx, dy);
      const bool valid = power >= pmin;
      const T a = math::SplatAlpha(o, power);  // computed for every lane, then selected
      const T alpha = valid ? a : T(0);
      const T w = alpha * f;
      sum_w[j] += w;
      red[j] += w * c0;
      green[j] += w * c1;
      blue[j] += w * c2;
      depth[j] += w * z;
      prod[j] *= T(1) - alpha;
      counted[j] += (power >= pmin_e) & (j < cols);
    }
  }
  int evaluations = 0;
  for (int j = 0; j < kTileSize; ++j) evaluations += counted[j];
  return evaluations;
}

template <typename T>
int64_t ForwardTileRowSorted(CpuState<T>* st, int ty, PoolVector<SortedTile<T>>* tiles) {
  const auto& cam = st->cam_;
  const int tiles_x = cam.tiles_x;
  // Tiles with live pixels, one bit each: most entries late in the walk only
  // reach finished tiles and are skipped with a word test.
  uint64_t live[kMaxTilesX / 64] = {};
  int active_tiles = 0;
  for (int tx = 0; tx < tiles_x; ++tx) {
    InitSortedTile(&(*tiles)[tx], MakeTileBox(tx, ty, cam.width, cam.height));
    if ((*tiles)[tx].active > 0) {
      live[tx / 64] |= uint64_t{1} << (tx % 64);
      ++active_tiles;
    }
  }
  int64_t evaluations = 0;
  const RowEntry* list = st->row_list_.data();
  int64_t q = st->row_begin_[ty];
  for (const int64_t end = st->row_begin_[ty + 1]; q < end && active_tiles > 0; ++q) {
    const RowEntry e = list[q];
    for (int w = e.x0 / 64; w <= e.x1 / 64; ++w) {
      // Bits of word w inside [x0, x1].
      const int lo = std::max(0, e.x0 - 64 * w), hi = std::min(63, e.x1 - 64 * w);
      uint64_t bits = live[w] & ((~uint64_t{0} >> (63 - hi)) & (~uint64_t{0} << lo));
      while (bits) {
        const int tx = 64 * w + __builtin_ctzll(bits);
        bits &= bits - 1;
        SortedTile<T>& t = (*tiles)[tx];
        evaluations += RasterizeSorted(&t, MakeTileBox(tx, ty, cam.width, cam.height), st->packed_[e.rank], e.rank + 1);
        if (t.active == 0) {
          live[w] &= ~(uint64_t{1} << (tx % 64));
          --active_tiles;
        }
      }
    }
  }
  st->row_scan_end_[ty] = q;
  for (int tx = 0; tx < tiles_x; ++tx) {
    const SortedTile<T>& t = (*tiles)[tx];
    const TileBox box = MakeTileBox(tx, ty, cam.width, cam.height);
    for (int py = box.y0; py <= box.y1; ++py) {
      for (int j = 0; j < box.cols; ++j) {
        const int i = (py - box.y0) * kTileSize + j;
        const size_t o = static_cast<size_t>(py) * cam.width + box.x0 + j;
        st->color_[3 * o] = t.red[i] + t.trans[i] * st->background_[0];
        st->color_[3 * o + 1] = t.green[i] + t.trans[i] * st->background_[1];
        st->color_[3 * o + 2] = t.blue[i] + t.trans[i] * st->background_[2];
        st->depth_[o] = t.depth[i];
        st->final_transmittance_[o] = t.trans[i];
        st->num_contrib_[o] = t.last[i];
      }
    }
  }
  return evaluations;
}

template <typename T>
int64_t ForwardTileRowOit(CpuState<T>* st, int ty, PoolVector<OitTile<T>>* tiles) {
  const auto& cam = st->cam_;
  const int tiles_x = cam.tiles_x;
  for (int tx = 0; tx < tiles_x; ++tx) {
    OitTile<T>& t = (*tiles)[tx];
    for (int i = 0; i < kTilePixels; ++i) {
      t.sum_w[i] = t.red[i] = t.green[i] = t.blue[i] = t.depth[i] = T(0);
      t.prod[i] = T(1);
    }
  }
  int64_t evaluations = 0;
  const RowEntry* list = st->row_list_.data();
  for (int64_t q = st->row_begin_[ty]; q < st->row_begin_[ty + 1]; ++q) {
    const RowEntry e = list[q];
    for (int tx = e.x0; tx <= e.x1; ++tx) {
      evaluations += RasterizeOit(&(*tiles)[tx], MakeTileBox(tx, ty, cam.width, cam.height), st->packed_[e.rank]);
    }
  }
  st->row_scan_end_[ty] = st->row_begin_[ty + 1];
  for (int tx = 0; tx < tiles_x; ++tx) {
    const OitTile<T>& t = (*tiles)[tx];
    const TileBox box = MakeTileBox(tx, ty, cam.width, cam.height);
    for (int py = box.y0; py <= box.y1; ++py) {
      for (int j = 0; j < box.cols; ++j) {
        const int i = (py - box.y0) * kTileSize + j;
        const size_t o = static_cast<size_t>(py) * cam.width + box.x0 + j;
        const T A = t.sum_w[i], P = t.prod[i];
        st->sum_weight_[o] = A;
        st->prod_transmit_[o] = P;
        const T wc[3] = {t.red[i], t.green[i], t.blue[i]};
        for (int c = 0; c < 3; ++c) {
          const T mean = A > T(0) ? wc[c] / A : T(0);
          st->mean_color_[3 * o + c] = mean;
          st->color_[3 * o + c] = mean * (T(1) - P) + P * st->background_[c];
        }
        const T mean_depth = A > T(0) ? t.depth[i] / A : T(0);
        st->mean_depth_[o] = mean_depth;
        st->depth_[o] = mean_depth * (T(1) - P);
        st->final_transmittance_[o] = P;
      }
    }
  }
  return evaluations;
}

// ---------------------------------------------------------------------------
// Backward. Again one thread per tile row, walking the same ranks (up to where
// the forward stopped). Per Gaussian, 16-lane accumulators collect its
// screen-space gradients over every pixel row of every tile it reaches in the
// tile row; they are summed over lanes in a fixed order into the Gaussian's
// slot for that tile row. The per-Gaussian sums over tile rows run in row
// order afterwards, so nothing depends on the thread count.

template <typename T>
inline void AddScreenGrads(ScreenGrads<T>* dst, const ScreenGrads<T>& src) {
  dst->v_mean_x += src.v_mean_x;
  dst->v_mean_y += src.v_mean_y;
  dst->v_A += src.v_A;
  dst->v_B += src.v_B;
  dst->v_C += src.v_C;
  for (int c = 0; c < 3; ++c) dst->v_color[c] += src.v_color[c];
  dst->v_opacity += src.v_opacity;
  dst->v_depth += src.v_depth;
}

template <typename T>
struct PixelGrads {
  const T* v_color;
  const T* v_depth;
  const T* v_alpha;
  T color(size_t o, int c) const { return v_color ? v_color[3 * o + c] : T(0); }
  T depth(size_t o) const { return v_depth ? v_depth[o] : T(0); }
  T alpha(size_t o) const { return v_alpha ? v_alpha[o] : T(0); }
};

// Per-lane accumulators of one Gaussian's ScreenGrads.
template <typename T>
struct LaneGrads {
  alignas(64) T mean_x[kTileSize];
  alignas(64) T mean_y[kTileSize];
  alignas(64) T A[kTileSize];
  alignas(64) T B[kTileSize];
  alignas(64) T C[kTileSize];
  alignas(64) T red[kTileSize];
  alignas(64) T green[kTileSize];
  alignas(64) T blue[kTileSize];
  alignas(64) T opacity[kTileSize];
  alignas(64) T depth[kTileSize];

  void Clear() {
    for (int j = 0; j < kTileSize; ++j) {
      mean_x[j] = mean_y[j] = A[j] = B[j] = C[j] = T(0);
      red[j] = green[j] = blue[j] = opacity[j] = depth[j] = T(0);
    }
  }
  void Add(const LaneGrads& o) {
    for (int j = 0; j < kTileSize; ++j) {
      mean_x[j] += o.mean_x[j];
      mean_y[j] += o.mean_y[j];
      A[j] += o.A[j];
      B[j] += o.B[j];
      C[j] += o.C[j];
      red[j] += o.red[j];
      green[j] += o.green[j];
      blue[j] += o.blue[j];
      opacity[j] += o.opacity[j];
      depth[j] += o.depth[j];
    }
  }
  // Lanes summed pairwise in a fixed order.
  static T Sum(const T* v) {
    T s[kTileSize / 2];
    for (int j = 0; j < kTileSize / 2; ++j) s[j] = v[j] + v[j + kTileSize / 2];
    for (int w = kTileSize / 4; w >= 1; w /= 2) {
      for (int j = 0; j < w; ++j) s[j] += s[j + w];
    }
    return s[0];
  }
  ScreenGrads<T> Reduce() const {
    ScreenGrads<T> g;
    g.v_mean_x = Sum(mean_x);
    g.v_mean_y = Sum(mean_y);
    g.v_A = Sum(A);
    g.v_B = Sum(B);
    g.v_C = Sum(C);
    g.v_color[0] = Sum(red);
    g.v_color[1] = Sum(green);
    g.v_color[2] = Sum(blue);
    g.v_opacity = Sum(opacity);
    g.v_depth = Sum(depth);
    return g;
  }
};

// Per-pixel state of the sorted backward for one tile.
template <typename T>
struct SortedBackTile {
  alignas(64) T trans[kTilePixels];     // T_i, recomputed front to back
  alignas(64) T suffix_r[kTilePixels];  // colour still to come behind (with background)
  alignas(64) T suffix_g[kTilePixels];
  alignas(64) T suffix_b[kTilePixels];
  alignas(64) T suffix_d[kTilePixels];  // depth still to come behind
  alignas(64) T v_r[kTilePixels];       // dL/d colour
  alignas(64) T v_g[kTilePixels];
  alignas(64) T v_b[kTilePixels];
  alignas(64) T v_d[kTilePixels];       // dL/d depth
  alignas(64) T v_at[kTilePixels];      // dL/d alpha_out * T_final
  alignas(64) int32_t last[kTilePixels];
  int32_t row_last[kTileSize];          // max of `last` per row
  int32_t max_last;
};

// The VJP of SplatAlpha (math::SplatAlphaVjpG) for one lane, branch-free:
// a lane that is invalid or clamped at 0.99 contributes zero.
template <typename T>
inline void AccumulateAlphaVjp(LaneGrads<T>* g, int j, bool unclamped, T G, T alpha, T v_a, T A, T B, T C, T dx,
                               T dy) {
  const T v_power = unclamped ? alpha * v_a : T(0);
  g->opacity[j] += unclamped ? G * v_a : T(0);
  g->A[j] += T(-0.5) * dx * dx * v_power;
  g->B[j] += -dx * dy * v_power;
  g->C[j] += T(-0.5) * dy * dy * v_power;
  g->mean_x[j] += (A * dx + B * dy) * v_power;
  g->mean_y[j] += (B * dx + C * dy) * v_power;
}

// Sorted compositing, reversed for one Gaussian (0-based rank k) in one tile.
// math::SortedAlphaGrad with the suffix kept directly: S -= w c.
template <typename T>
void BackwardSorted(SortedBackTile<T>* t, TileBox box, const Packed<T>& s, int32_t k, LaneGrads<T>* out) {
  int py0, py1;
  TileRowRange(s, box, &py0, &py1);
  const T A = s.A, B = s.B, C = s.C, o = s.opacity, pmin = s.power_min;
  const T mx = s.mean_x, my = s.mean_y, c0 = s.color[0], c1 = s.color[1], c2 = s.color[2], z = s.depth;
  const int x0 = box.x0;
  LaneGrads<T> acc;  // local: no aliasing with the tile, kept close
  acc.Clear();
  LaneGrads<T>* g = &acc;
  for (int py = py0; py <= py1; ++py) {
    const int row = py - box.y0;
    if (k >= t->row_last[row]) continue;
    const T dy = T(py) - my;
    const int b = row * kTileSize;
    T* __restrict trans = t->trans + b;
    T* __restrict sr = t->suffix_r + b;
    T* __restrict sg = t->suffix_g + b;
    T* __restrict sb = t->suffix_b + b;
    T* __restrict sd = t->suffix_d + b;
    const T* __restrict vr = t->v_r + b;
    const T* __restrict vg = t->v_g + b;
    const T* __restrict vb = t->v_b + b;
    const T* __restrict vd = t->v_d + b;
    const T* __restrict vat = t->v_at + b;
    const int32_t* __restrict last = t->last + b;
    for (int j = 0; j < kTileSize; ++j) {
      const T dx = T(x0 + j) - mx;
      const T power = math::SplatPower(A, B, C, dx, dy);
      const T G = math::ExpNonPositive(power);
      const T a = o * G;
      const T alpha = a < T(math::kMaxAlpha) ? a : T(math::kMaxAlpha);  // math::SplatAlpha
      const bool valid = (k < last[j]) & (power >= pmin);
      const T tr = trans[j];
      const T w = valid ? alpha * tr : T(0);
      sr[j] -= w * c0;
      sg[j] -= w * c1;
      sb[j] -= w * c2;
      sd[j] -= w * z;
      const T inv = T(1) / (T(1) - alpha);
      const T v_a = vr[j] * (tr * c0 - sr[j] * inv) + vg[j] * (tr * c1 - sg[j] * inv) +
                    vb[j] * (tr * c2 - sb[j] * inv) + vd[j] * (tr * z - sd[j] * inv) + vat[j] * inv;
      g->red[j] += valid ? w * vr[j] : T(0);
      g->green[j] += valid ? w * vg[j] : T(0);
      g->blue[j] += valid ? w * vb[j] : T(0);
      g->depth[j] += valid ? w * vd[j] : T(0);
      AccumulateAlphaVjp(g, j, valid & (a < T(math::kMaxAlpha)), G, alpha, v_a, A, B, C, dx, dy);
      trans[j] = valid ? tr * (T(1) - alpha) : tr;
    }
  }
  out->Add(acc);
}

// Per-pixel state of the order-independent backward for one tile: the
// constants of math::OitPixelVjp, regrouped so a lane needs few operations:
// with K = 1 - P, kA = K / A, dc = v_C . c - v_C . Cbar:
//   v_alpha_i = f kA (dc + v_D (z - Dbar)) + Q / (1 - alpha_i),
//   Q = P (v_C . (Cbar - bg) + v_D Dbar + v_alpha_out),
//   v_c_i = alpha_i f kA v_C,
//   v_z_i = dc alpha_i f' kA + v_D (alpha_i f kA + (z - Dbar) alpha_i f' kA).
template <typename T>
struct OitBackTile {
  alignas(64) T k_a[kTilePixels];
  alignas(64) T v_r[kTilePixels];
  alignas(64) T v_g[kTilePixels];
  alignas(64) T v_b[kTilePixels];
  alignas(64) T v_d[kTilePixels];
  alignas(64) T v_cc[kTilePixels];  // v_C . Cbar
  alignas(64) T dbar[kTilePixels];
  alignas(64) T q[kTilePixels];
};

template <typename T>
void BackwardOit(const OitBackTile<T>& t, TileBox box, const Packed<T>& s, LaneGrads<T>* out) {
  int py0, py1;
  TileRowRange(s, box, &py0, &py1);
  const T A = s.A, B = s.B, C = s.C, o = s.opacity, pmin = s.power_min;
  const T mx = s.mean_x, my = s.mean_y, c0 = s.color[0], c1 = s.color[1], c2 = s.color[2], z = s.depth;
  const T f = s.oit_f, dfdz = s.oit_dfdz;
  const int x0 = box.x0, cols = box.cols;
  LaneGrads<T> acc;
  acc.Clear();
  LaneGrads<T>* g = &acc;
  for (int py = py0; py <= py1; ++py) {
    const T dy = T(py) - my;
    const int b = (py - box.y0) * kTileSize;
    const T* __restrict k_a = t.k_a + b;
    const T* __restrict vr = t.v_r + b;
    const T* __restrict vg = t.v_g + b;
    const T* __restrict vb = t.v_b + b;
    const T* __restrict vd = t.v_d + b;
    const T* __restrict vcc = t.v_cc + b;
    const T* __restrict dbar = t.dbar + b;
    const T* __restrict q = t.q + b;
    for (int j = 0; j < kTileSize; ++j) {
      const T dx = T(x0 + j) - mx;
      const T power = math::SplatPower(A, B, C, dx, dy);
      const T G = math::ExpNonPositive(power);
      const T a = o * G;
      const T alpha = a < T(math::kMaxAlpha) ? a : T(math::kMaxAlpha);
      const bool valid = (power >= pmin) & (j < cols);
      const T fa = f * k_a[j];
      const T dfa = alpha * dfdz * k_a[j];
      const T dc = vr[j] * c0 + vg[j] * c1 + vb[j] * c2 - vcc[j];
      const T zd = z - dbar[j];
      const T v_a = fa * (dc + vd[j] * zd) + q[j] / (T(1) - alpha);
      const T af = alpha * fa;
      g->red[j] += valid ? af * vr[j] : T(0);
      g->green[j] += valid ? af * vg[j] : T(0);
      g->blue[j] += valid ? af * vb[j] : T(0);
      g->depth[j] += valid ? dc * dfa + vd[j] * (alpha * fa + zd * dfa) : T(0);
      AccumulateAlphaVjp(g, j, valid & (a < T(math::kMaxAlpha)), G, alpha, v_a, A, B, C, dx, dy);
    }
  }
  out->Add(acc);
}

// A Gaussian's screen-space gradients from one tile row.
template <typename T>
struct RowGrads {
  int32_t rank;
  ScreenGrads<T> g;
};

// Appends, in rank order, the gradients of every Gaussian that reached a
// pixel of tile row ty to `out` (room for the row's list); returns how many.
template <typename T>
int64_t BackwardTileRow(const CpuState<T>& st, int ty, const PixelGrads<T>& pg, RowGrads<T>* out,
                        PoolVector<SortedBackTile<T>>* sorted_tiles, PoolVector<OitBackTile<T>>* oit_tiles) {
  const auto& cam = st.cam_;
  const int tiles_x = cam.tiles_x;
  const bool sorted = st.mode_ == CompositeMode::kSorted;
  const int64_t scan_end = st.row_scan_end_[ty];
  const int32_t all_ranks = static_cast<int32_t>(st.order_.size());
  PoolVector<int32_t> tile_end(tiles_x, 0);  // ranks below this can touch the tile
  for (int tx = 0; tx < tiles_x; ++tx) {
    const TileBox box = MakeTileBox(tx, ty, cam.width, cam.height);
    if (sorted) {
      SortedBackTile<T>& t = (*sorted_tiles)[tx];
      std::memset(static_cast<void*>(&t), 0, sizeof(t));
      for (int py = box.y0; py <= box.y1; ++py) {
        int32_t row_last = 0;
        for (int j = 0; j < box.cols; ++j) {
          const int i = (py - box.y0) * kTileSize + j;
          const size_t o = static_cast<size_t>(py) * cam.width + box.x0 + j;
          t.trans[i] = T(1);
          t.suffix_r[i] = st.color_[3 * o];
          t.suffix_g[i] = st.color_[3 * o + 1];
          t.suffix_b[i] = st.color_[3 * o + 2];
          t.suffix_d[i] = st.depth_[o];
          t.v_r[i] = pg.color(o, 0);
          t.v_g[i] = pg.color(o, 1);
          t.v_b[i] = pg.color(o, 2);
          t.v_d[i] = pg.depth(o);
          t.v_at[i] = pg.alpha(o) * st.final_transmittance_[o];
          t.last[i] = st.num_contrib_[o];
          row_last = std::max(row_last, t.last[i]);
        }
        t.row_last[py - box.y0] = row_last;
        t.max_last = std::max(t.max_last, row_last);
      }
      tile_end[tx] = t.max_last;
    } else {
      OitBackTile<T>& t = (*oit_tiles)[tx];
      std::memset(static_cast<void*>(&t), 0, sizeof(t));
      for (int py = box.y0; py <= box.y1; ++py) {
        for (int j = 0; j < box.cols; ++j) {
          const int i = (py - box.y0) * kTileSize + j;
          const size_t o = static_cast<size_t>(py) * cam.width + box.x0 + j;
          const T A = st.sum_weight_[o], P = st.prod_transmit_[o];
          const T cbar[3] = {st.mean_color_[3 * o], st.mean_color_[3 * o + 1], st.mean_color_[3 * o + 2]};
          const T vc[3] = {pg.color(o, 0), pg.color(o, 1), pg.color(o, 2)};
          const T dbar = st.mean_depth_[o];
          t.k_a[i] = A > T(0) ? (T(1) - P) / A : T(0);
          t.v_r[i] = vc[0];
          t.v_g[i] = vc[1];
          t.v_b[i] = vc[2];
          t.v_d[i] = pg.depth(o);
          t.v_cc[i] = vc[0] * cbar[0] + vc[1] * cbar[1] + vc[2] * cbar[2];
          t.dbar[i] = dbar;
          T vcb = T(0);
          for (int c = 0; c < 3; ++c) vcb += vc[c] * (cbar[c] - st.background_[c]);
          t.q[i] = P * (vcb + t.v_d[i] * dbar + pg.alpha(o));
        }
      }
      tile_end[tx] = all_ranks;
    }
  }

  LaneGrads<T> lanes;
  int64_t count = 0;
  const RowEntry* list = st.row_list_.data();
  for (int64_t q = st.row_begin_[ty]; q < scan_end; ++q) {
    const RowEntry e = list[q];
    const Packed<T>& s = st.packed_[e.rank];
    bool touched = false;
    for (int tx = e.x0; tx <= e.x1; ++tx) {
      if (e.rank >= tile_end[tx]) continue;
      if (!touched) lanes.Clear();
      touched = true;
      const TileBox box = MakeTileBox(tx, ty, cam.width, cam.height);
      if (sorted) {
        BackwardSorted(&(*sorted_tiles)[tx], box, s, e.rank, &lanes);
      } else {
        BackwardOit((*oit_tiles)[tx], box, s, &lanes);
      }
    }
    if (touched) out[count++] = {e.rank, lanes.Reduce()};
  }
  return count;
}

class CpuRasterizer : public Rasterizer {
 public:
  Backend backend() const override { return Backend::kCpu; }
  std::unique_ptr<RasterState> Forward(const GaussianParams& params, const RasterCamera& camera,
                                       const RasterSettings& settings, const RasterOutputs& outputs) override {
    return cpu::Forward<float>(params, camera, settings, outputs);
  }
  void Backward(const RasterState& state, const GaussianParams& params, const RasterCamera& camera,
                const RasterSettings& settings, const RasterOutputGrads& output_grads,
                const GaussianGrads& grads) override {
    cpu::Backward<float>(state, params, camera, settings, output_grads, grads);
  }
};

}  // namespace

template <typename T>
std::unique_ptr<RasterState> Forward(const GaussianParamsT<T>& params, const RasterCamera& camera,
                                     const RasterSettings& settings, const RasterOutputsT<T>& outputs) {
  ValidateRasterInputs(params, camera, settings);
  DYPHO_CHECK_INPUT(outputs.color && outputs.depth && outputs.alpha)
      << "rasterizer outputs: color, depth and alpha buffers are required";

  auto st = std::make_unique<CpuState<T>>();
  st->mode_ = settings.mode;
  const int nt = ThreadCount(settings);
  st->num_threads_ = nt;
  st->cam_ = math::MakeCameraData<T>(camera, settings, params.sh_coeffs);
  for (int c = 0; c < 3; ++c) st->background_[c] = T(settings.background[c]);
  const auto& cam = st->cam_;
  const int n = params.num_gaussians;
  const size_t pixels = static_cast<size_t>(camera.width) * camera.height;
  st->projected_.resize(n);
  st->status_.assign(n, math::kCulled);

  // 1. Per-Gaussian projection.
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int i = 0; i < n; ++i) {
    st->status_[i] = static_cast<uint8_t>(ProjectOne(i, params, cam, &st->projected_[i]));
  }
  PoolVector<int32_t>& order = st->order_;
  order.reserve(n);
  int nonfinite = 0;
  for (int i = 0; i < n; ++i) {
    if (st->status_[i] == math::kVisible) order.push_back(i);
    if (st->status_[i] == math::kNonFinite) ++nonfinite;
  }
  st->stats_.num_gaussians = n;
  st->stats_.num_visible = static_cast<int>(order.size());
  st->stats_.num_nonfinite = nonfinite;
  if (outputs.radii) {
    for (int i = 0; i < n; ++i) outputs.radii[i] = st->status_[i] == math::kVisible ? st->projected_[i].radius : 0;
  }

  // 2. Compositing order: depth, ties by index; the OIT sum keeps index order.
  if (settings.mode == CompositeMode::kSorted) SortByDepth(st->projected_, &order);
  const int v = static_cast<int>(order.size());

  // 3. Per rank: the packed footprint and its tile rows; then per touched
  // tile row the exact x-extent of the enlarged ellipse within the row's band
  // of pixel centres (math::EllipseBandExtent), as tile columns.
  st->packed_.resize(v);
  st->tile_rows_.resize(v);
  st->span_base_.resize(v + 1);
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int r = 0; r < v; ++r) {
    const Projected<T>& p = st->projected_[order[r]];
    const auto& s = p.splat;
    const math::SplatT<T> e = Enlarged(s);
    Packed<T>& k = st->packed_[r];
    k.mean_x = s.mean_x;
    k.mean_y = s.mean_y;
    k.A = s.A;
    k.B = s.B;
    k.C = s.C;
    k.opacity = s.opacity;
    k.power_min = s.power_min;
    k.power_min_culling = e.power_min;
    const T det = e.A * e.C - e.B * e.B;
    k.y_ext = std::sqrt(std::max(T(0), T(-2) * e.power_min * e.A / det));
    k.x_ext = std::sqrt(std::max(T(0), T(-2) * e.power_min * e.C / det));
    for (int c = 0; c < 3; ++c) k.color[c] = p.color[c];
    k.depth = p.depth;
    k.oit_f = math::OitWeight(p.depth, &k.oit_dfdz);
    st->tile_rows_[r] = {static_cast<int16_t>(p.tile_y0), static_cast<int16_t>(p.tile_y1)};
    st->span_base_[r + 1] = p.tile_y1 - p.tile_y0;
  }
  st->span_base_[0] = 0;
  for (int r = 0; r < v; ++r) st->span_base_[r + 1] += st->span_base_[r];
  const int64_t num_entries = st->span_base_[v];
  st->spans_.resize(static_cast<size_t>(num_entries));
  const int tiles_y = cam.tiles_y;
  const int chunks = (v + kRankChunk - 1) / kRankChunk;
  PoolVector<int64_t> row_counts(static_cast<size_t>(chunks) * tiles_y, 0);  // [chunk, tile row]
  int64_t pairs = 0;
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt) reduction(+ : pairs)
  for (int c = 0; c < chunks; ++c) {
    int64_t* counts = &row_counts[static_cast<size_t>(c) * tiles_y];
    for (int r = c * kRankChunk; r < std::min(v, (c + 1) * kRankChunk); ++r) {
      const Projected<T>& p = st->projected_[order[r]];
      const math::SplatT<T> e = Enlarged(p.splat);
      const math::EllipseExtents<T> extents = math::MakeEllipseExtents(e);
      Span* spans = &st->spans_[st->span_base_[r]];
      for (int ty = p.tile_y0; ty < p.tile_y1; ++ty) {
        const int y0 = ty * kTileSize, y1 = std::min(y0 + kTileSize, cam.height) - 1;
        T lo, hi;
        int a = 1, b = 0;
        if (math::EllipseBandExtent(e, extents, T(y0) - e.mean_y, T(y1) - e.mean_y, &lo, &hi)) {
          ClippedRange(std::floor((e.mean_x + lo) / T(kTileSize)), std::floor((e.mean_x + hi) / T(kTileSize)),
                       p.tile_x0, p.tile_x1 - 1, &a, &b);
        }
        spans[ty - p.tile_y0] = {static_cast<int16_t>(a), static_cast<int16_t>(b)};
        pairs += std::max(0, b - a + 1);
        counts[ty] += a <= b;
      }
    }
  }
  st->stats_.num_tile_pairs = pairs;
  // Row lists: row ty holds chunk 0's entries, then chunk 1's, ...
  st->row_begin_.resize(tiles_y + 1);
  int64_t total = 0;
  for (int ty = 0; ty < tiles_y; ++ty) {
    st->row_begin_[ty] = total;
    for (int c = 0; c < chunks; ++c) {
      const int64_t count = row_counts[static_cast<size_t>(c) * tiles_y + ty];
      row_counts[static_cast<size_t>(c) * tiles_y + ty] = total;  // becomes the chunk's write cursor
      total += count;
    }
  }
  st->row_begin_[tiles_y] = total;
  st->row_list_.resize(static_cast<size_t>(total));
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
  for (int c = 0; c < chunks; ++c) {
    int64_t* cursor = &row_counts[static_cast<size_t>(c) * tiles_y];
    for (int r = c * kRankChunk; r < std::min(v, (c + 1) * kRankChunk); ++r) {
      const TileRows rows = st->tile_rows_[r];
      const int64_t base = st->span_base_[r];
      for (int ty = rows.y0; ty < rows.y1; ++ty) {
        const Span span = st->spans_[base + (ty - rows.y0)];
        if (span.x0 <= span.x1) st->row_list_[cursor[ty]++] = {r, span.x0, span.x1};
      }
    }
  }

  // 4. Rasterize, one tile row per task.
  st->color_.resize(pixels * 3);
  st->depth_.resize(pixels);
  st->final_transmittance_.resize(pixels);
  st->row_scan_end_.resize(cam.tiles_y);  // written per row below
  PoolVector<int64_t> evaluations(cam.tiles_y, 0);
  const bool sorted = settings.mode == CompositeMode::kSorted;
  if (sorted) {
    st->num_contrib_.resize(pixels);
  } else {
    st->sum_weight_.resize(pixels);
    st->prod_transmit_.resize(pixels);
    st->mean_color_.resize(pixels * 3);
    st->mean_depth_.resize(pixels);
  }
#pragma omp parallel num_threads(nt)
  {
    PoolVector<SortedTile<T>> sorted_tiles(sorted ? cam.tiles_x : 0);
    PoolVector<OitTile<T>> oit_tiles(sorted ? 0 : cam.tiles_x);
#pragma omp for schedule(dynamic, 1)
    for (int ty = 0; ty < cam.tiles_y; ++ty) {
      evaluations[ty] = sorted ? ForwardTileRowSorted(st.get(), ty, &sorted_tiles)
                               : ForwardTileRowOit(st.get(), ty, &oit_tiles);
    }
  }
  st->stats_.num_evaluations = std::accumulate(evaluations.begin(), evaluations.end(), int64_t{0});
  std::memcpy(outputs.color, st->color_.data(), sizeof(T) * pixels * 3);
  std::memcpy(outputs.depth, st->depth_.data(), sizeof(T) * pixels);
  for (size_t o = 0; o < pixels; ++o) outputs.alpha[o] = T(1) - st->final_transmittance_[o];
  return st;
}

template <typename T>
void Backward(const RasterState& state, const GaussianParamsT<T>& params, const RasterCamera& camera,
              const RasterSettings& settings, const RasterOutputGradsT<T>& output_grads,
              const GaussianGradsT<T>& grads) {
  const auto* st = dynamic_cast<const CpuState<T>*>(&state);
  DYPHO_CHECK_INPUT(st != nullptr) << "rasterizer backward: the state does not come from the CPU backend "
                                      "with this precision";
  DYPHO_CHECK_INPUT(static_cast<int>(st->projected_.size()) == params.num_gaussians)
      << "rasterizer backward: " << params.num_gaussians << " Gaussians given, forward saw "
      << st->projected_.size();
  DYPHO_CHECK_INPUT(st->mode_ == settings.mode) << "rasterizer backward: compositing mode differs from forward";
  DYPHO_CHECK_INPUT(st->cam_.width == camera.width && st->cam_.height == camera.height)
      << "rasterizer backward: image size differs from forward";
  const int n = params.num_gaussians;
  const auto& cam = st->cam_;
  const int nt = st->num_threads_;

  // Per tile row, the gradients of the Gaussians that reached its pixels, in
  // rank order, in the row's part of a buffer laid out like the row lists.
  const int tiles_y = cam.tiles_y;
  PoolVector<RowGrads<T>> row_grads(st->row_list_.size());
  PoolVector<int64_t> row_grads_end(tiles_y);
  const PixelGrads<T> pg{output_grads.v_color, output_grads.v_depth, output_grads.v_alpha};
  const bool sorted = st->mode_ == CompositeMode::kSorted;
#pragma omp parallel num_threads(nt)
  {
    PoolVector<SortedBackTile<T>> sorted_tiles(sorted ? cam.tiles_x : 0);
    PoolVector<OitBackTile<T>> oit_tiles(sorted ? 0 : cam.tiles_x);
#pragma omp for schedule(dynamic, 1)
    for (int ty = 0; ty < tiles_y; ++ty) {
      const int64_t begin = st->row_begin_[ty];
      row_grads_end[ty] = begin + BackwardTileRow(*st, ty, pg, row_grads.data() + begin, &sorted_tiles, &oit_tiles);
    }
  }

  // Per Gaussian: sum its tile rows' gradients in row order. Fixed blocks of
  // ranks; each block takes its part of every row (rows are in rank order),
  // so the sums do not depend on the thread count. Stored by Gaussian index.
  const int v = static_cast<int>(st->order_.size());
  PoolVector<ScreenGrads<T>> screen_grads(n);
  const int blocks = (v + kRankChunk - 1) / kRankChunk;
#pragma omp parallel num_threads(nt)
  {
    PoolVector<ScreenGrads<T>> block_sums(kRankChunk);
#pragma omp for schedule(dynamic, 1)
    for (int b = 0; b < blocks; ++b) {
      const int32_t r0 = b * kRankChunk, r1 = std::min(v, r0 + kRankChunk);
      for (int32_t r = r0; r < r1; ++r) block_sums[r - r0] = ScreenGrads<T>{};
      for (int ty = 0; ty < tiles_y; ++ty) {
        const RowGrads<T>* first = row_grads.data() + st->row_begin_[ty];
        const RowGrads<T>* last = row_grads.data() + row_grads_end[ty];
        first = std::lower_bound(first, last, r0, [](const RowGrads<T>& e, int32_t r) { return e.rank < r; });
        for (; first != last && first->rank < r1; ++first) AddScreenGrads(&block_sums[first->rank - r0], first->g);
      }
      for (int32_t r = r0; r < r1; ++r) screen_grads[st->order_[r]] = block_sums[r - r0];
    }
  }
  const int K = params.sh_coeffs;
  const int active = math::ShCoeffsForDegree(cam.sh_degree);
  const bool want_pose = grads.v_cam_twist != nullptr;
  PoolVector<T> pose_parts(want_pose ? static_cast<size_t>(n) * 12 : 0, T(0));
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int i = 0; i < n; ++i) {
    T v_mean[3] = {0, 0, 0}, v_ls[3] = {0, 0, 0}, v_q[4] = {0, 0, 0, 0}, v_logit = 0;
    T v_sh[3 * kMaxShCoeffs] = {};
    T mean2d_abs = 0;
    if (st->status_[i] == math::kVisible) {
      const ScreenGrads<T>& g = screen_grads[i];
      math::Mat3<T> v_R(T(0));
      Vec3<T> v_t(T(0));
      ProjectOneVjp(i, params, cam, st->projected_[i].clamped, g, v_mean, v_ls, v_q, &v_logit, v_sh, &v_R, &v_t);
      mean2d_abs = std::sqrt(g.v_mean_x * g.v_mean_x + g.v_mean_y * g.v_mean_y);
      if (want_pose) {
        T* part = &pose_parts[static_cast<size_t>(i) * 12];
        for (int rr = 0; rr < 3; ++rr) {
          for (int c = 0; c < 3; ++c) part[3 * rr + c] = v_R[c][rr];
          part[9 + rr] = v_t[rr];
        }
      }
    }
    if (grads.v_means) std::copy(v_mean, v_mean + 3, grads.v_means + 3 * i);
    if (grads.v_log_scales) std::copy(v_ls, v_ls + 3, grads.v_log_scales + 3 * i);
    if (grads.v_quats) std::copy(v_q, v_q + 4, grads.v_quats + 4 * i);
    if (grads.v_opacity_logits) grads.v_opacity_logits[i] = v_logit;
    if (grads.v_sh) {
      T* dst = grads.v_sh + static_cast<size_t>(3) * K * i;
      for (int k = 0; k < 3 * K; ++k) dst[k] = k < 3 * active ? v_sh[k] : T(0);
    }
    if (grads.v_mean2d_abs) grads.v_mean2d_abs[i] = mean2d_abs;
  }
  if (want_pose) {
    // Fixed chunks, summed in order: independent of the thread count.
    double total[12] = {};
    constexpr int kChunk = 4096;
    const int chunks = (n + kChunk - 1) / kChunk;
    PoolVector<double> chunk_sums(static_cast<size_t>(chunks) * 12, 0.0);
#pragma omp parallel for schedule(static) num_threads(nt)
    for (int c = 0; c < chunks; ++c) {
      for (int i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i) {
        for (int j = 0; j < 12; ++j) chunk_sums[12 * c + j] += pose_parts[12 * static_cast<size_t>(i) + j];
      }
    }
    for (int c = 0; c < chunks; ++c) {
      for (int j = 0; j < 12; ++j) total[j] += chunk_sums[12 * c + j];
    }
    math::Mat3<T> v_R;
    Vec3<T> v_t;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) v_R[c][r] = T(total[3 * r + c]);
      v_t[r] = T(total[9 + r]);
    }
    math::PoseGradToTwist(cam.R, cam.t, v_R, v_t, grads.v_cam_twist);
  }
}

template std::unique_ptr<RasterState> Forward<float>(const GaussianParamsT<float>&, const RasterCamera&,
                                                     const RasterSettings&, const RasterOutputsT<float>&);
template std::unique_ptr<RasterState> Forward<double>(const GaussianParamsT<double>&, const RasterCamera&,
                                                      const RasterSettings&, const RasterOutputsT<double>&);
template void Backward<float>(const RasterState&, const GaussianParamsT<float>&, const RasterCamera&,
                              const RasterSettings&, const RasterOutputGradsT<float>&,
                              const GaussianGradsT<float>&);
template void Backward<double>(const RasterState&, const GaussianParamsT<double>&, const RasterCamera&,
                               const RasterSettings&, const RasterOutputGradsT<double>&,
                               const GaussianGradsT<double>&);

std::unique_ptr<Rasterizer> CreateCpuRasterizer() {
  KeepFreedMemory();
  return std::make_unique<CpuRasterizer>();
}

}  // namespace dypho::kernels::cpu
