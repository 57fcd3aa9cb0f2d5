#include "kernels/cpu/cpu_rasterizer.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <vector>

#include "common/check.h"
#include "common/files.h"
#include "kernels/math/preprocess.h"

namespace dypho::kernels::cpu {
namespace {

using math::CameraData;
using math::Projected;
using math::ScreenGrads;
using math::Vec3;

constexpr int kTilePixels = kTileSize * kTileSize;

template <typename T>
class CpuState : public RasterState {
 public:
  RasterStats stats() const override { return stats_; }

  RasterStats stats_;
  CompositeMode mode_ = CompositeMode::kSorted;
  CameraData<T> cam_;
  int num_threads_ = 1;
  std::vector<Projected<T>> projected_;  // [N]
  std::vector<uint8_t> status_;          // [N] math::ProjectStatus
  std::vector<std::vector<int32_t>> tile_lists_;  // [tiles] Gaussian ids, front to back
  // Sorted mode, per pixel.
  std::vector<T> final_transmittance_;  // [H*W]
  std::vector<int32_t> num_contrib_;    // [H*W] tile-list prefix length used
  std::vector<T> color_;                // [H*W*3] output colour (with background)
  std::vector<T> depth_;                // [H*W]
  // Order-independent mode, per pixel.
  std::vector<T> sum_weight_;    // [H*W] A
  std::vector<T> prod_transmit_; // [H*W] P
  std::vector<T> mean_color_;    // [H*W*3] Cbar
  std::vector<T> mean_depth_;    // [H*W] Dbar
  T background_[3] = {0, 0, 0};
};

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

// Pixel rows [*py0, *py1] of a tile (rows y0..y1) that the footprint reaches.
template <typename T>
inline void RowRange(const math::SplatT<T>& e, int y0, int y1, int* py0, int* py1) {
  const T det = e.A * e.C - e.B * e.B;
  const T y_ext = std::sqrt(std::max(T(0), T(-2) * e.power_min * e.A / det));
  *py0 = std::max(y0, static_cast<int>(std::ceil(e.mean_y - y_ext)));
  *py1 = std::min(y1, static_cast<int>(std::floor(e.mean_y + y_ext)));
}

// Pixel columns [*px0, *px1] within x0..x1 that the footprint reaches on row py.
template <typename T>
inline bool ColumnSpan(const math::SplatT<T>& e, int py, int x0, int x1, int* px0, int* px1) {
  T lo, hi;
  if (!math::EllipseSpanAt(e, T(py) - e.mean_y, &lo, &hi)) return false;
  *px0 = std::max(x0, static_cast<int>(std::ceil(e.mean_x + lo)));
  *px1 = std::min(x1, static_cast<int>(std::floor(e.mean_x + hi)));
  return *px0 <= *px1;
}

// Each tile row is handled by one thread, which walks the Gaussians in
// (depth, index) order and appends each to the tiles its footprint reaches in
// that row: an exact x-extent of the ellipse within the row's band of pixel
// centres (math::EllipseBandExtent), so no per-tile test is needed.
template <typename T>
void BuildTileLists(CpuState<T>* st, const std::vector<int32_t>& order) {
  const auto& cam = st->cam_;
  st->tile_lists_.assign(static_cast<size_t>(cam.tiles_x) * cam.tiles_y, {});
  // Gaussians per tile row, in order.
  std::vector<std::vector<int32_t>> rows(cam.tiles_y);
  for (int32_t g : order) {
    const Projected<T>& p = st->projected_[g];
    for (int ty = p.tile_y0; ty < p.tile_y1; ++ty) rows[ty].push_back(g);
  }
#pragma omp parallel for schedule(dynamic, 1) num_threads(st->num_threads_)
  for (int ty = 0; ty < cam.tiles_y; ++ty) {
    const int y0 = ty * kTileSize, y1 = std::min(y0 + kTileSize, cam.height) - 1;
    std::vector<std::pair<int16_t, int16_t>> spans(rows[ty].size());
    std::vector<int32_t> counts(cam.tiles_x, 0);
    for (size_t j = 0; j < rows[ty].size(); ++j) {
      const Projected<T>& p = st->projected_[rows[ty][j]];
      const math::SplatT<T> e = Enlarged(p.splat);
      T lo, hi;
      int a = 1, b = 0;
      if (math::EllipseBandExtent(e, T(y0) - e.mean_y, T(y1) - e.mean_y, &lo, &hi)) {
        a = std::max(p.tile_x0, static_cast<int>(std::floor((e.mean_x + lo) / T(kTileSize))));
        b = std::min(p.tile_x1 - 1, static_cast<int>(std::floor((e.mean_x + hi) / T(kTileSize))));
      }
      spans[j] = {static_cast<int16_t>(a), static_cast<int16_t>(b)};
      for (int tx = a; tx <= b; ++tx) ++counts[tx];
    }
    for (int tx = 0; tx < cam.tiles_x; ++tx) {
      st->tile_lists_[static_cast<size_t>(ty) * cam.tiles_x + tx].reserve(counts[tx]);
    }
    for (size_t j = 0; j < rows[ty].size(); ++j) {
      for (int tx = spans[j].first; tx <= spans[j].second; ++tx) {
        st->tile_lists_[static_cast<size_t>(ty) * cam.tiles_x + tx].push_back(rows[ty][j]);
      }
    }
  }
  int64_t pairs = 0;
  for (const auto& l : st->tile_lists_) pairs += static_cast<int64_t>(l.size());
  st->stats_.num_tile_pairs = pairs;
}

// The per-row pixel loops below are branch-free (selects instead of
// `continue`) over structure-of-arrays tile buffers so the compiler can
// vectorize them; the arithmetic per pixel is exactly the scalar definition.
template <typename T>
int64_t ForwardTileSorted(CpuState<T>* st, int tile) {
  const auto& cam = st->cam_;
  const int tx = tile % cam.tiles_x, ty = tile / cam.tiles_x;
  const int x0 = tx * kTileSize, y0 = ty * kTileSize;
  const int x1 = std::min(x0 + kTileSize, cam.width) - 1, y1 = std::min(y0 + kTileSize, cam.height) - 1;
  alignas(64) T trans[kTilePixels], cr[kTilePixels], cg[kTilePixels], cb[kTilePixels], depth[kTilePixels];
  alignas(64) int32_t last[kTilePixels], done[kTilePixels];
  for (int i = 0; i < kTilePixels; ++i) {
    trans[i] = T(1);
    cr[i] = cg[i] = cb[i] = depth[i] = T(0);
    last[i] = 0;
    done[i] = 0;
  }
  int active = (x1 - x0 + 1) * (y1 - y0 + 1);
  int64_t evaluations = 0;
  const auto& list = st->tile_lists_[tile];
  for (size_t k = 0; k < list.size() && active > 0; ++k) {
    const Projected<T>& p = st->projected_[list[k]];
    const auto& s = p.splat;
    const math::SplatT<T> e = Enlarged(s);
    const T A = s.A, B = s.B, C = s.C, o = s.opacity, pmin = s.power_min, mx = s.mean_x;
    const T c0 = p.color[0], c1 = p.color[1], c2 = p.color[2], z = p.depth;
    const int32_t order = static_cast<int32_t>(k + 1);
    int py0, py1, px0, px1;
    RowRange(e, y0, y1, &py0, &py1);
    int terminated = 0;
    for (int py = py0; py <= py1; ++py) {
      if (!ColumnSpan(e, py, x0, x1, &px0, &px1)) continue;
      evaluations += px1 - px0 + 1;
      const T dy = T(py) - s.mean_y;
      const int base = (py - y0) * kTileSize - x0;
      for (int px = px0; px <= px1; ++px) {
        const int i = base + px;
        const T dx = T(px) - mx;
        const T power = T(-0.5) * (A * dx * dx + C * dy * dy) - B * dx * dy;
        const T alpha = math::SplatAlpha(o, power);
        const T next = trans[i] * (T(1) - alpha);
        const bool valid = (power >= pmin) & (done[i] == 0);
        const bool stop = valid & (next < T(math::kMinTransmittance));
        const bool add = valid & !stop;
        const T w = add ? alpha * trans[i] : T(0);
        cr[i] += w * c0;
        cg[i] += w * c1;
        cb[i] += w * c2;
        depth[i] += w * z;
        trans[i] = add ? next : trans[i];
        last[i] = add ? order : last[i];
        done[i] |= static_cast<int32_t>(stop);
        terminated += stop;
      }
    }
    active -= terminated;
  }
  for (int py = y0; py <= y1; ++py) {
    for (int px = x0; px <= x1; ++px) {
      const int i = (py - y0) * kTileSize + (px - x0);
      const size_t o = static_cast<size_t>(py) * cam.width + px;
      st->color_[3 * o] = cr[i] + trans[i] * st->background_[0];
      st->color_[3 * o + 1] = cg[i] + trans[i] * st->background_[1];
      st->color_[3 * o + 2] = cb[i] + trans[i] * st->background_[2];
      st->depth_[o] = depth[i];
      st->final_transmittance_[o] = trans[i];
      st->num_contrib_[o] = last[i];
    }
  }
  return evaluations;
}

template <typename T>
int64_t ForwardTileOit(CpuState<T>* st, int tile) {
  const auto& cam = st->cam_;
  const int tx = tile % cam.tiles_x, ty = tile / cam.tiles_x;
  const int x0 = tx * kTileSize, y0 = ty * kTileSize;
  const int x1 = std::min(x0 + kTileSize, cam.width) - 1, y1 = std::min(y0 + kTileSize, cam.height) - 1;
  T sum_w[kTilePixels], prod[kTilePixels], wcolor[kTilePixels * 3], wdepth[kTilePixels];
  for (int i = 0; i < kTilePixels; ++i) {
    sum_w[i] = T(0);
    prod[i] = T(1);
    wcolor[3 * i] = wcolor[3 * i + 1] = wcolor[3 * i + 2] = T(0);
    wdepth[i] = T(0);
  }
  int64_t evaluations = 0;
  for (int32_t g : st->tile_lists_[tile]) {
    const Projected<T>& p = st->projected_[g];
    const auto& s = p.splat;
    T dfdz;
    const T f = math::OitWeight(p.depth, &dfdz);
    const math::SplatT<T> e = Enlarged(s);
    int py0, py1, px0, px1;
    RowRange(e, y0, y1, &py0, &py1);
    for (int py = py0; py <= py1; ++py) {
      if (!ColumnSpan(e, py, x0, x1, &px0, &px1)) continue;
      evaluations += px1 - px0 + 1;
      const T dy = T(py) - s.mean_y;
      for (int px = px0; px <= px1; ++px) {
        const int i = (py - y0) * kTileSize + (px - x0);
        const T dx = T(px) - s.mean_x;
        const T power = math::SplatPower(s.A, s.B, s.C, dx, dy);
        const bool valid = power >= s.power_min;
        const T alpha = valid ? math::SplatAlpha(s.opacity, power) : T(0);
        const T w = alpha * f;
        sum_w[i] += w;
        wcolor[3 * i] += w * p.color[0];
        wcolor[3 * i + 1] += w * p.color[1];
        wcolor[3 * i + 2] += w * p.color[2];
        wdepth[i] += w * p.depth;
        prod[i] *= T(1) - alpha;
      }
    }
  }
  for (int py = y0; py <= y1; ++py) {
    for (int px = x0; px <= x1; ++px) {
      const int i = (py - y0) * kTileSize + (px - x0);
      const size_t o = static_cast<size_t>(py) * cam.width + px;
      const T A = sum_w[i], P = prod[i];
      st->sum_weight_[o] = A;
      st->prod_transmit_[o] = P;
      for (int c = 0; c < 3; ++c) {
        const T mean = A > T(0) ? wcolor[3 * i + c] / A : T(0);
        st->mean_color_[3 * o + c] = mean;
        st->color_[3 * o + c] = mean * (T(1) - P) + P * st->background_[c];
      }
      const T mean_depth = A > T(0) ? wdepth[i] / A : T(0);
      st->mean_depth_[o] = mean_depth;
      st->depth_[o] = mean_depth * (T(1) - P);
      st->final_transmittance_[o] = P;
    }
  }
  return evaluations;
}

// ---------------------------------------------------------------------------
// Backward

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
  Vec3<T> color(size_t o) const {
    return v_color ? Vec3<T>(v_color[3 * o], v_color[3 * o + 1], v_color[3 * o + 2]) : Vec3<T>(T(0));
  }
  T depth(size_t o) const { return v_depth ? v_depth[o] : T(0); }
  T alpha(size_t o) const { return v_alpha ? v_alpha[o] : T(0); }
};

// Backward for one tile; accumulates into `slots` at slot_of(g).
template <typename T, typename SlotFn>
void BackwardTileSorted(const CpuState<T>& st, int tile, const PixelGrads<T>& pg, SlotFn slot_of) {
  const auto& cam = st.cam_;
  const int tx = tile % cam.tiles_x, ty = tile / cam.tiles_x;
  const int x0 = tx * kTileSize, y0 = ty * kTileSize;
  const int x1 = std::min(x0 + kTileSize, cam.width) - 1, y1 = std::min(y0 + kTileSize, cam.height) - 1;
  T trans[kTilePixels], final_trans[kTilePixels], pre_color[kTilePixels * 3], pre_depth[kTilePixels];
  Vec3<T> out_color[kTilePixels], v_color[kTilePixels];
  T out_depth[kTilePixels], v_depth[kTilePixels], v_alpha[kTilePixels];
  int32_t last[kTilePixels];
  int32_t max_last = 0;
  for (int i = 0; i < kTilePixels; ++i) last[i] = 0;
  for (int py = y0; py <= y1; ++py) {
    for (int px = x0; px <= x1; ++px) {
      const int i = (py - y0) * kTileSize + (px - x0);
      const size_t o = static_cast<size_t>(py) * cam.width + px;
      trans[i] = T(1);
      final_trans[i] = st.final_transmittance_[o];
      pre_color[3 * i] = pre_color[3 * i + 1] = pre_color[3 * i + 2] = T(0);
      pre_depth[i] = T(0);
      out_color[i] = Vec3<T>(st.color_[3 * o], st.color_[3 * o + 1], st.color_[3 * o + 2]);
      out_depth[i] = st.depth_[o];
      v_color[i] = pg.color(o);
      v_depth[i] = pg.depth(o);
      v_alpha[i] = pg.alpha(o);
      last[i] = st.num_contrib_[o];
      max_last = std::max(max_last, last[i]);
    }
  }
  const auto& list = st.tile_lists_[tile];
  for (int32_t k = 0; k < max_last; ++k) {
    const int32_t g = list[k];
    const Projected<T>& p = st.projected_[g];
    const auto& s = p.splat;
    const Vec3<T> c(p.color[0], p.color[1], p.color[2]);
    ScreenGrads<T> acc{};
    bool touched = false;
    const math::SplatT<T> e = Enlarged(s);
    int py0, py1, px0, px1;
    RowRange(e, y0, y1, &py0, &py1);
    for (int py = py0; py <= py1; ++py) {
      if (!ColumnSpan(e, py, x0, x1, &px0, &px1)) continue;
      const T dy = T(py) - s.mean_y;
      for (int px = px0; px <= px1; ++px) {
        const int i = (py - y0) * kTileSize + (px - x0);
        if (k >= last[i]) continue;
        const T dx = T(px) - s.mean_x;
        const T power = math::SplatPower(s.A, s.B, s.C, dx, dy);
        if (power < s.power_min) continue;
        touched = true;
        const T alpha = math::SplatAlpha(s.opacity, power);
        const T w = alpha * trans[i];
        pre_color[3 * i] += w * c.x;
        pre_color[3 * i + 1] += w * c.y;
        pre_color[3 * i + 2] += w * c.z;
        pre_depth[i] += w * p.depth;
        const Vec3<T> suffix_color =
            out_color[i] - Vec3<T>(pre_color[3 * i], pre_color[3 * i + 1], pre_color[3 * i + 2]);
        const T suffix_depth = out_depth[i] - pre_depth[i];
        const T v_a = math::SortedAlphaGrad(alpha, trans[i], c, p.depth, suffix_color, suffix_depth,
                                            final_trans[i], v_color[i], v_depth[i], v_alpha[i]);
        acc.v_color[0] += w * v_color[i].x;
        acc.v_color[1] += w * v_color[i].y;
        acc.v_color[2] += w * v_color[i].z;
        acc.v_depth += w * v_depth[i];
        math::SplatAlphaVjp(s.opacity, power, s.A, s.B, s.C, dx, dy, v_a, &acc.v_opacity, &acc.v_A, &acc.v_B,
                            &acc.v_C, &acc.v_mean_x, &acc.v_mean_y);
        trans[i] *= T(1) - alpha;
      }
    }
    if (touched) AddScreenGrads(slot_of(g), acc);
  }
}

template <typename T, typename SlotFn>
void BackwardTileOit(const CpuState<T>& st, int tile, const PixelGrads<T>& pg, SlotFn slot_of) {
  const auto& cam = st.cam_;
  const int tx = tile % cam.tiles_x, ty = tile / cam.tiles_x;
  const int x0 = tx * kTileSize, y0 = ty * kTileSize;
  const int x1 = std::min(x0 + kTileSize, cam.width) - 1, y1 = std::min(y0 + kTileSize, cam.height) - 1;
  const Vec3<T> bg(st.background_[0], st.background_[1], st.background_[2]);
  for (int32_t g : st.tile_lists_[tile]) {
    const Projected<T>& p = st.projected_[g];
    const auto& s = p.splat;
    const Vec3<T> c(p.color[0], p.color[1], p.color[2]);
    T dfdz;
    const T f = math::OitWeight(p.depth, &dfdz);
    ScreenGrads<T> acc{};
    bool touched = false;
    const math::SplatT<T> e = Enlarged(s);
    int py0, py1, px0, px1;
    RowRange(e, y0, y1, &py0, &py1);
    for (int py = py0; py <= py1; ++py) {
      if (!ColumnSpan(e, py, x0, x1, &px0, &px1)) continue;
      const T dy = T(py) - s.mean_y;
      for (int px = px0; px <= px1; ++px) {
        const T dx = T(px) - s.mean_x;
        const T power = math::SplatPower(s.A, s.B, s.C, dx, dy);
        if (power < s.power_min) continue;
        touched = true;
        const size_t o = static_cast<size_t>(py) * cam.width + px;
        const T alpha = math::SplatAlpha(s.opacity, power);
        const Vec3<T> mean_color(st.mean_color_[3 * o], st.mean_color_[3 * o + 1], st.mean_color_[3 * o + 2]);
        Vec3<T> v_c(T(0));
        T v_a = T(0), v_z = T(0);
        math::OitPixelVjp(alpha, c, p.depth, f, dfdz, st.sum_weight_[o], st.prod_transmit_[o], mean_color,
                          st.mean_depth_[o], bg, pg.color(o), pg.depth(o), pg.alpha(o), &v_c, &v_a, &v_z);
        acc.v_color[0] += v_c.x;
        acc.v_color[1] += v_c.y;
        acc.v_color[2] += v_c.z;
        acc.v_depth += v_z;
        math::SplatAlphaVjp(s.opacity, power, s.A, s.B, s.C, dx, dy, v_a, &acc.v_opacity, &acc.v_A, &acc.v_B,
                            &acc.v_C, &acc.v_mean_x, &acc.v_mean_y);
      }
    }
    if (touched) AddScreenGrads(slot_of(g), acc);
  }
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
  st->num_threads_ = ThreadCount(settings);
  st->cam_ = math::MakeCameraData<T>(camera, settings, params.sh_coeffs);
  for (int c = 0; c < 3; ++c) st->background_[c] = T(settings.background[c]);
  const int n = params.num_gaussians;
  const size_t pixels = static_cast<size_t>(camera.width) * camera.height;
  st->projected_.resize(n);
  st->status_.assign(n, math::kCulled);

  // 1. Per-Gaussian projection.
#pragma omp parallel for schedule(static) num_threads(st->num_threads_)
  for (int i = 0; i < n; ++i) {
    st->status_[i] = static_cast<uint8_t>(math::ProjectGaussian(i, params.means, params.log_scales, params.quats,
                                                                params.opacity_logits, params.sh,
                                                                params.sh_coeffs, st->cam_, &st->projected_[i]));
  }
  std::vector<int32_t> order;
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

  // 2. Depth order (front to back, ties by index); the OIT sum needs no order.
  if (settings.mode == CompositeMode::kSorted) {
    std::stable_sort(order.begin(), order.end(), [&](int32_t a, int32_t b) {
      return st->projected_[a].depth < st->projected_[b].depth;
    });
  }
  // 3. Tile lists.
  BuildTileLists(st.get(), order);

  // 4. Rasterize tiles.
  st->color_.assign(pixels * 3, T(0));
  st->depth_.assign(pixels, T(0));
  st->final_transmittance_.assign(pixels, T(1));
  const int tiles = st->cam_.tiles_x * st->cam_.tiles_y;
  std::vector<int64_t> evaluations(tiles, 0);
  if (settings.mode == CompositeMode::kSorted) {
    st->num_contrib_.assign(pixels, 0);
#pragma omp parallel for schedule(dynamic, 1) num_threads(st->num_threads_)
    for (int t = 0; t < tiles; ++t) evaluations[t] = ForwardTileSorted(st.get(), t);
  } else {
    st->sum_weight_.assign(pixels, T(0));
    st->prod_transmit_.assign(pixels, T(1));
    st->mean_color_.assign(pixels * 3, T(0));
    st->mean_depth_.assign(pixels, T(0));
#pragma omp parallel for schedule(dynamic, 1) num_threads(st->num_threads_)
    for (int t = 0; t < tiles; ++t) evaluations[t] = ForwardTileOit(st.get(), t);
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

  // One accumulator per (Gaussian, tile row) it touches.
  std::vector<int64_t> slot_base(n + 1, 0);
  for (int i = 0; i < n; ++i) {
    const int rows = st->status_[i] == math::kVisible ? st->projected_[i].tile_y1 - st->projected_[i].tile_y0 : 0;
    slot_base[i + 1] = slot_base[i] + rows;
  }
  std::vector<ScreenGrads<T>> slots(static_cast<size_t>(slot_base[n]));
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t s = 0; s < slot_base[n]; ++s) slots[s] = ScreenGrads<T>{};

  const PixelGrads<T> pg{output_grads.v_color, output_grads.v_depth, output_grads.v_alpha};
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
  for (int ty = 0; ty < cam.tiles_y; ++ty) {
    auto slot_of = [&](int32_t g) { return &slots[slot_base[g] + (ty - st->projected_[g].tile_y0)]; };
    for (int tx = 0; tx < cam.tiles_x; ++tx) {
      const int tile = ty * cam.tiles_x + tx;
      if (st->mode_ == CompositeMode::kSorted) {
        BackwardTileSorted(*st, tile, pg, slot_of);
      } else {
        BackwardTileOit(*st, tile, pg, slot_of);
      }
    }
  }

  // Per Gaussian: sum the row accumulators in row order, then the chain back
  // to the parameters. Pose gradients per Gaussian, summed afterwards.
  const int K = params.sh_coeffs;
  const int active = math::ShCoeffsForDegree(cam.sh_degree);
  const bool want_pose = grads.v_cam_twist != nullptr;
  std::vector<T> pose_parts(want_pose ? static_cast<size_t>(n) * 12 : 0, T(0));
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int i = 0; i < n; ++i) {
    T v_mean[3] = {0, 0, 0}, v_ls[3] = {0, 0, 0}, v_q[4] = {0, 0, 0, 0}, v_logit = 0;
    T v_sh[3 * kMaxShCoeffs] = {};
    T mean2d_abs = 0;
    if (st->status_[i] == math::kVisible) {
      ScreenGrads<T> g{};
      for (int64_t s = slot_base[i]; s < slot_base[i + 1]; ++s) AddScreenGrads(&g, slots[s]);
      math::Mat3<T> v_R(T(0));
      Vec3<T> v_t(T(0));
      math::ProjectGaussianVjp(i, params.means, params.log_scales, params.quats, params.opacity_logits, params.sh,
                               K, cam, st->projected_[i].clamped, g, v_mean, v_ls, v_q, &v_logit, v_sh, &v_R,
                               &v_t);
      mean2d_abs = std::sqrt(g.v_mean_x * g.v_mean_x + g.v_mean_y * g.v_mean_y);
      if (want_pose) {
        T* part = &pose_parts[static_cast<size_t>(i) * 12];
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) part[3 * r + c] = v_R[c][r];
          part[9 + r] = v_t[r];
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
    std::vector<double> chunk_sums(static_cast<size_t>(chunks) * 12, 0.0);
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
