// The CPU backend's own structure: tile-row walks, the live-tile bitset on
// images wider than 64 tiles, pooled (not zero-filled) buffers reused across
// calls. Checked against an independent per-pixel compositing of the
// definition in kernels/rasterizer.h, and bit-for-bit across repeated calls.
#include "kernels/cpu/cpu_rasterizer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>

#include "kernels/math/preprocess.h"
#include "tests/raster_scene.h"

namespace dypho::kernels {
namespace {

using testing::Grads;
using testing::MakeCamera;
using testing::RandomScene;
using testing::Render;
using testing::Scene;

// The definition, pixel by pixel: every visible Gaussian (math::ProjectGaussian,
// tested on its own in kernels_math_test) tested at every pixel, no tiles.
Render<double> ReferenceRender(const Scene<double>& s, const RasterCamera& camera, const RasterSettings& set) {
  const auto cam = math::MakeCameraData<double>(camera, set, s.sh_coeffs);
  std::vector<math::Projected<double>> proj(s.n);
  std::vector<int> visible;
  for (int i = 0; i < s.n; ++i) {
    if (math::ProjectGaussian(i, s.means.data(), s.log_scales.data(), s.quats.data(), s.opacity_logits.data(),
                              s.sh.data(), s.sh_coeffs, cam, &proj[i]) == math::kVisible) {
      visible.push_back(i);
    }
  }
  std::stable_sort(visible.begin(), visible.end(), [&](int a, int b) { return proj[a].depth < proj[b].depth; });
  Render<double> r(camera.width, camera.height, s.n);
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      double t = 1, c[3] = {0, 0, 0}, d = 0;        // sorted
      double a_sum = 0, p = 1, wc[3] = {0, 0, 0}, wd = 0;  // order-independent
      for (int i : visible) {
        const auto& g = proj[i];
        const double dx = x - g.splat.mean_x, dy = y - g.splat.mean_y;
        const double power = -0.5 * (g.splat.A * dx * dx + g.splat.C * dy * dy) - g.splat.B * dx * dy;
        if (power < g.splat.power_min) continue;
        const double alpha = std::min(0.99, g.splat.opacity * std::exp(power));
        if (set.mode == CompositeMode::kSorted) {
          if (t * (1 - alpha) < 1e-4) break;
          for (int k = 0; k < 3; ++k) c[k] += alpha * t * g.color[k];
          d += alpha * t * g.depth;
          t *= 1 - alpha;
        } else {
          double dfdz;
          const double f = math::OitWeight(g.depth, &dfdz);
          a_sum += alpha * f;
          for (int k = 0; k < 3; ++k) wc[k] += alpha * f * g.color[k];
          wd += alpha * f * g.depth;
          p *= 1 - alpha;
        }
      }
      const size_t o = size_t(y) * camera.width + x;
      for (int k = 0; k < 3; ++k) {
        r.color[3 * o + k] = set.mode == CompositeMode::kSorted
                                 ? c[k] + t * set.background[k]
                                 : (a_sum > 0 ? wc[k] / a_sum : 0) * (1 - p) + p * set.background[k];
      }
      r.depth[o] = set.mode == CompositeMode::kSorted ? d : (a_sum > 0 ? wd / a_sum : 0) * (1 - p);
      r.alpha[o] = set.mode == CompositeMode::kSorted ? 1 - t : 1 - p;
    }
  }
  return r;
}

// 1100 pixels = 69 tiles across: the live-tile bitset spans two words.
TEST(CpuRasterizer, WideImageMatchesPerPixelDefinition) {
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    Scene<double> s = RandomScene<double>(400, 1, 71, 1.0, 5.0, 0.02, 0.3, 0.0, 3.0);
    // Spread the means along x so Gaussians cross the 64-tile word boundary.
    for (int i = 0; i < s.n; ++i) s.means[3 * i] *= 10.0;
    const RasterCamera cam = MakeCamera(1100, 40, 120.0);
    RasterSettings set;
    set.mode = mode;
    set.background[1] = 0.25f;
    set.num_threads = 2;
    Render<double> got(cam.width, cam.height, s.n);
    const auto state = cpu::Forward<double>(s.params(), cam, set, got.outputs());
    ASSERT_GT(state->stats().num_visible, 300);
    const Render<double> want = ReferenceRender(s, cam, set);
    int covered_right = 0;  // pixels with content beyond tile 64
    for (size_t o = 0; o < want.alpha.size(); ++o) {
      ASSERT_NEAR(got.alpha[o], want.alpha[o], 1e-9) << "pixel " << o << " mode " << CompositeModeName(mode);
      ASSERT_NEAR(got.depth[o], want.depth[o], 1e-8) << "pixel " << o;
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(got.color[3 * o + k], want.color[3 * o + k], 1e-9) << "pixel " << o;
      covered_right += (o % cam.width) >= 64 * kTileSize && want.alpha[o] > 0.5;
    }
    EXPECT_GT(covered_right, 1000);
  }
}

// Buffers come from a pool and are not zero-filled: a render after renders of
// other sizes must give the same bits as the first.
TEST(CpuRasterizer, RepeatedCallsWithOtherSizesInBetweenAreBitIdentical) {
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    const Scene<float> a = RandomScene<float>(1500, 4, 81, 1.0, 6.0, 0.01, 0.25);
    const Scene<float> b = RandomScene<float>(6000, 1, 82, 1.0, 6.0, 0.01, 0.4);
    const RasterCamera cam_a = MakeCamera(200, 150, 160.0), cam_b = MakeCamera(333, 222, 250.0);
    RasterSettings set;
    set.mode = mode;
    set.num_threads = 2;
    const size_t px = size_t(cam_a.width) * cam_a.height;
    std::vector<float> vc(px * 3), vd(px), va(px);
    for (size_t i = 0; i < px; ++i) {
      vd[i] = std::sin(0.1f * i);
      va[i] = std::cos(0.07f * i);
      for (int k = 0; k < 3; ++k) vc[3 * i + k] = std::sin(0.013f * i + k);
    }
    auto run = [&](const Scene<float>& s, const RasterCamera& cam, Render<float>* r, Grads<float>* g) {
      auto st = cpu::Forward<float>(s.params(), cam, set, r->outputs());
      if (g) cpu::Backward<float>(*st, s.params(), cam, set, {vc.data(), vd.data(), va.data()}, g->grads());
    };
    Render<float> first(cam_a.width, cam_a.height, a.n), again(cam_a.width, cam_a.height, a.n);
    Grads<float> g_first(a), g_again(a);
    run(a, cam_a, &first, &g_first);
    Render<float> other(cam_b.width, cam_b.height, b.n);
    Grads<float> g_other(b);
    run(b, cam_b, &other, &g_other);
    run(a, cam_a, &again, &g_again);
    auto same = [](const std::vector<float>& x, const std::vector<float>& y) {
      return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(float)) == 0;
    };
    EXPECT_TRUE(same(first.color, again.color));
    EXPECT_TRUE(same(first.depth, again.depth));
    EXPECT_TRUE(same(first.alpha, again.alpha));
    EXPECT_TRUE(same(g_first.means, g_again.means));
    EXPECT_TRUE(same(g_first.quats, g_again.quats));
    EXPECT_TRUE(same(g_first.sh, g_again.sh));
    EXPECT_TRUE(same(g_first.twist, g_again.twist));
    EXPECT_GT(*std::max_element(first.alpha.begin(), first.alpha.end()), 0.5f);
  }
}

}  // namespace
}  // namespace dypho::kernels
