// What the CPU backend's forward (cpu_forward.cc) and backward
// (cpu_backward.cc) passes share: the per-Gaussian data the pixel loops read,
// the state the forward keeps for the backward, and the tile geometry. Internal
// to the kernels library (kernels/cpu/cpu_rasterizer.h is the interface).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "kernels/cpu/block_pool.h"
#include "kernels/math/preprocess.h"
#include "kernels/rasterizer.h"

namespace dypho::kernels::cpu {

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

// Ranks are binned into tile rows in fixed chunks (independent of the thread
// count), so each row list comes out in rank order.
constexpr int kRankChunk = 2048;

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

}  // namespace dypho::kernels::cpu
