// The CPU backend's backward pass (kernels/cpu/cpu_rasterizer.h): per tile
// row, the same ranks as the forward, gradients summed in a fixed order.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <type_traits>

#include "common/check.h"
#include "kernels/cpu/cpu_raster_common.h"
#include "kernels/cpu/cpu_rasterizer.h"

namespace dypho::kernels::cpu {
namespace {

template <typename T>
DYPHO_FLATTEN void ProjectOneVjp(int i, const GaussianParamsT<T>& params, const CameraData<T>& cam, unsigned clamped,
                                 const ScreenGrads<T>& g, T* v_mean, T* v_ls, T* v_q, T* v_logit, T* v_sh,
                                 math::Mat3<T>* v_R, Vec3<T>* v_t) {
  math::ProjectGaussianVjp(i, params.means, params.log_scales, params.quats, params.opacity_logits, params.sh,
                           params.sh_coeffs, cam, clamped, g, v_mean, v_ls, v_q, v_logit, v_sh, v_R, v_t);
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

}  // namespace

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

template void Backward<float>(const RasterState&, const GaussianParamsT<float>&, const RasterCamera&,
                              const RasterSettings&, const RasterOutputGradsT<float>&,
                              const GaussianGradsT<float>&);
template void Backward<double>(const RasterState&, const GaussianParamsT<double>&, const RasterCamera&,
                               const RasterSettings&, const RasterOutputGradsT<double>&,
                               const GaussianGradsT<double>&);

}  // namespace dypho::kernels::cpu
