// The CPU backend's forward pass (kernels/cpu/cpu_rasterizer.h):
// preprocessing, depth sort, binning into tile rows and compositing.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <type_traits>

#include "common/check.h"
#include "common/files.h"
#include "kernels/cpu/cpu_raster_common.h"
#include "kernels/cpu/cpu_rasterizer.h"

namespace dypho::kernels::cpu {
namespace {

template <typename T>
DYPHO_FLATTEN int ProjectOne(int i, const GaussianParamsT<T>& params, const CameraData<T>& cam, Projected<T>* out) {
  return math::ProjectGaussian(i, params.means, params.log_scales, params.quats, params.opacity_logits, params.sh,
                               params.sh_coeffs, cam, out);
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

template std::unique_ptr<RasterState> Forward<float>(const GaussianParamsT<float>&, const RasterCamera&,
                                                     const RasterSettings&, const RasterOutputsT<float>&);
template std::unique_ptr<RasterState> Forward<double>(const GaussianParamsT<double>&, const RasterCamera&,
                                                      const RasterSettings&, const RasterOutputsT<double>&);

}  // namespace dypho::kernels::cpu
