// The CPU reference rasterizer as a whole: finite differences in double
// precision (both modes, pose included), known answers, determinism across
// thread counts, and bad input.
#include <cmath>
#include <cstring>
#include <random>

#include <gtest/gtest.h>

#include "common/check.h"
#include "common/rigid3.h"
#include "kernels/cpu/cpu_rasterizer.h"
#include "kernels/rasterizer.h"
#include "tests/raster_scene.h"

namespace dypho::kernels {
namespace {

using testing::Grads;
using testing::MakeCamera;
using testing::RandomScene;
using testing::Render;
using testing::Scene;

// Loss weights: L = sum wc.color + sum wd.depth + sum wa.alpha.
struct LossWeights {
  std::vector<double> wc, wd, wa;
  LossWeights(int w, int h, unsigned seed) : wc(size_t(w) * h * 3), wd(size_t(w) * h), wa(size_t(w) * h) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    for (double& v : wc) v = u(rng);
    for (double& v : wd) v = 0.3 * u(rng);
    for (double& v : wa) v = u(rng);
  }
  double operator()(const Render<double>& r) const {
    double s = 0;
    for (size_t i = 0; i < wc.size(); ++i) s += wc[i] * r.color[i];
    for (size_t i = 0; i < wd.size(); ++i) s += wd[i] * r.depth[i] + wa[i] * r.alpha[i];
    return s;
  }
};

double RenderLoss(const Scene<double>& s, const RasterCamera& cam, const RasterSettings& set, const LossWeights& w) {
  Render<double> r(cam.width, cam.height, s.n);
  cpu::Forward<double>(s.params(), cam, set, r.outputs());
  return w(r);
}

RasterCamera Perturbed(const RasterCamera& cam, int axis, double h) {
  Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
  xi[axis] = h;
  Eigen::Matrix<double, 3, 4> m;
  for (int i = 0; i < 12; ++i) m(i / 4, i % 4) = cam.cam_from_world[i];
  const Rigid3d pose = Rigid3d::Exp(xi) * Rigid3d::FromMatrix(m);
  const Eigen::Matrix<double, 3, 4> out = pose.ToMatrix();
  RasterCamera c = cam;
  for (int i = 0; i < 12; ++i) c.cam_from_world[i] = out(i / 4, i % 4);
  return c;
}

void CheckWholeRasterizerGradients(CompositeMode mode, int sh_coeffs, unsigned seed) {
  Scene<double> scene = RandomScene<double>(7, sh_coeffs, seed, 2.0, 4.0, 0.05, 0.25, -1.0, 1.0);
  RasterCamera cam = MakeCamera(40, 30, 36.0);
  cam = Perturbed(cam, 4, 0.05);  // a non-identity pose
  RasterSettings set;
  set.mode = mode;
  set.background[0] = 0.2f;
  set.background[1] = 0.4f;
  set.background[2] = 0.1f;
  set.num_threads = 2;
  const LossWeights w(cam.width, cam.height, seed + 100);

  Render<double> r(cam.width, cam.height, scene.n);
  auto state = cpu::Forward<double>(scene.params(), cam, set, r.outputs());
  ASSERT_GT(state->stats().num_visible, 3);
  RasterOutputGradsT<double> og{w.wc.data(), w.wd.data(), w.wa.data()};
  Grads<double> g(scene);
  cpu::Backward<double>(*state, scene.params(), cam, set, og, g.grads());

  const double h = 1e-7;
  auto scene_arrays = scene.arrays();
  auto grad_arrays = g.arrays();
  const char* names[] = {"means", "log_scales", "quats", "opacity_logits", "sh"};
  int checked = 0;
  for (size_t a = 0; a < scene_arrays.size(); ++a) {
    std::vector<double>& values = *scene_arrays[a];
    for (size_t i = 0; i < values.size(); ++i) {
      const double keep = values[i];
      values[i] = keep + h;
      const double lp = RenderLoss(scene, cam, set, w);
      values[i] = keep - h;
      const double lm = RenderLoss(scene, cam, set, w);
      values[i] = keep;
      const double numeric = (lp - lm) / (2 * h);
      const double analytic = (*grad_arrays[a])[i];
      EXPECT_NEAR(analytic, numeric, 1e-5 * std::max(1.0, std::abs(numeric)))
          << names[a] << "[" << i << "] mode " << CompositeModeName(mode);
      ++checked;
    }
  }
  for (int k = 0; k < 6; ++k) {
    const double lp = RenderLoss(scene, Perturbed(cam, k, h), set, w);
    const double lm = RenderLoss(scene, Perturbed(cam, k, -h), set, w);
    const double numeric = (lp - lm) / (2 * h);
    EXPECT_NEAR(g.twist[k], numeric, 1e-5 * std::max(1.0, std::abs(numeric))) << "twist[" << k << "]";
  }
  EXPECT_GE(checked, 7 * (3 + 3 + 4 + 1 + 3 * sh_coeffs));
}

TEST(Rasterizer, FiniteDifferenceSortedDegree0) { CheckWholeRasterizerGradients(CompositeMode::kSorted, 1, 21); }
TEST(Rasterizer, FiniteDifferenceSortedDegree3) { CheckWholeRasterizerGradients(CompositeMode::kSorted, 16, 22); }
TEST(Rasterizer, FiniteDifferenceOitDegree0) { CheckWholeRasterizerGradients(CompositeMode::kOrderIndependent, 1, 23); }
TEST(Rasterizer, FiniteDifferenceOitDegree2) { CheckWholeRasterizerGradients(CompositeMode::kOrderIndependent, 9, 24); }

// A Gaussian facing the camera: the image is the analytic 2D Gaussian with
// variance (f s / z)^2 + 0.3 (the low-pass dilation), cut at 3 sigma.
TEST(Rasterizer, IsotropicGaussianMatchesAnalytic) {
  Scene<double> s;
  const double z = 2.0, scale = 0.05, f = 100.0;
  const double mean[3] = {0, 0, z}, ls[3] = {std::log(scale), std::log(scale), std::log(scale)};
  const double q[4] = {1, 0, 0, 0};
  const double logit = 0.5;
  s.Add(mean, ls, q, logit, {0.4, 0.1, -0.2});
  const RasterCamera cam = MakeCamera(64, 64, f);
  RasterSettings set;
  set.background[0] = 0.1f;
  Render<double> r(cam.width, cam.height, 1);
  cpu::Forward<double>(s.params(), cam, set, r.outputs());
  const double opacity = 1 / (1 + std::exp(-logit));
  const double var = (f * scale / z) * (f * scale / z) + double(0.3f);  // settings.low_pass is float
  const double c0 = 0.28209479177387814;
  const double rgb[3] = {0.4 * c0 + 0.5, 0.1 * c0 + 0.5, -0.2 * c0 + 0.5};
  int inside = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      const double dx = x - 31.5, dy = y - 31.5;
      const double sigma2 = (dx * dx + dy * dy) / var;
      double alpha = opacity * std::exp(-0.5 * sigma2);
      if (sigma2 > 9.0 || alpha < 1.0 / 255.0) alpha = 0;
      inside += alpha > 0;
      const size_t o = size_t(y) * 64 + x;
      ASSERT_NEAR(r.alpha[o], alpha, 1e-12) << x << "," << y;
      ASSERT_NEAR(r.depth[o], alpha * z, 1e-12);
      ASSERT_NEAR(r.color[3 * o], rgb[0] * alpha + double(0.1f) * (1 - alpha), 1e-12);
      ASSERT_NEAR(r.color[3 * o + 1], rgb[1] * alpha, 1e-12);
    }
  }
  EXPECT_GT(inside, 100);
  EXPECT_EQ(r.radii[0], static_cast<int>(std::ceil(3 * std::sqrt(var))));
}

TEST(Rasterizer, NonOverlappingGaussiansSameInBothModes) {
  Scene<float> s;
  const float q[4] = {0.9f, 0.1f, 0.2f, 0.3f};
  const float m1[3] = {-0.4f, 0.0f, 2.0f}, m2[3] = {0.5f, 0.1f, 3.0f};
  const float ls[3] = {std::log(0.04f), std::log(0.02f), std::log(0.03f)};
  s.Add(m1, ls, q, 2.0f, {0.5f, -0.5f, 0.2f});
  s.Add(m2, ls, q, 1.0f, {-0.3f, 0.4f, 0.1f});
  const RasterCamera cam = MakeCamera(80, 60, 60.0);
  RasterSettings set;
  set.background[2] = 0.5f;
  Render<float> sorted(80, 60, 2), oit(80, 60, 2);
  auto rasterizer = CreateRasterizer(Backend::kCpu);
  rasterizer->Forward(s.params(), cam, set, sorted.outputs());
  set.mode = CompositeMode::kOrderIndependent;
  rasterizer->Forward(s.params(), cam, set, oit.outputs());
  int covered = 0;
  for (size_t i = 0; i < sorted.alpha.size(); ++i) {
    covered += sorted.alpha[i] > 0;
    ASSERT_NEAR(sorted.alpha[i], oit.alpha[i], 1e-6) << i;
    ASSERT_NEAR(sorted.depth[i], oit.depth[i], 1e-5) << i;
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(sorted.color[3 * i + c], oit.color[3 * i + c], 1e-6) << i;
  }
  EXPECT_GT(covered, 20);
}

TEST(Rasterizer, OpaqueFrontoParallelSplatDepthIsItsZ) {
  Scene<float> s;
  const float z = 1.7f;
  const float m[3] = {0.0f, 0.0f, z};
  const float ls[3] = {std::log(0.3f), std::log(0.3f), std::log(1e-4f)};  // a flat disc facing the camera
  const float q[4] = {1, 0, 0, 0};
  s.Add(m, ls, q, 12.0f, {0.0f, 0.0f, 0.0f});
  const RasterCamera cam = MakeCamera(64, 48, 50.0);
  RasterSettings set;
  Render<float> r(64, 48, 1);
  CreateRasterizer(Backend::kCpu)->Forward(s.params(), cam, set, r.outputs());
  const size_t centre = 24 * 64 + 32;
  EXPECT_FLOAT_EQ(r.alpha[centre], 0.99f);
  int checked = 0;
  for (size_t i = 0; i < r.alpha.size(); ++i) {
    if (r.alpha[i] > 0.5f) {
      EXPECT_NEAR(r.depth[i] / r.alpha[i], z, 1e-6f);
      ++checked;
    }
  }
  EXPECT_GT(checked, 50);
}

TEST(Rasterizer, EarlyTerminationLeavesBackGaussiansOut) {
  // Four discs of opacity 0.95 stacked on the axis: T = 0.05, 2.5e-3, 1.25e-4,
  // and the fourth would take T below 1e-4, so it is not composited.
  Scene<double> s;
  const double q[4] = {1, 0, 0, 0}, ls[3] = {std::log(0.5), std::log(0.5), std::log(1e-3)};
  const double logit = std::log(19.0);  // opacity 0.95
  for (double z : {1.0, 1.5, 2.0, 2.5}) {
    const double m[3] = {0, 0, z};
    s.Add(m, ls, q, logit, {1.0, 0.0, 0.0});
  }
  const RasterCamera cam = MakeCamera(17, 17, 10.0);  // pixel (8, 8) is on the axis
  RasterSettings set;
  Render<double> r(17, 17, 4);
  cpu::Forward<double>(s.params(), cam, set, r.outputs());
  const size_t c = 8 * 17 + 8;
  EXPECT_NEAR(r.depth[c], 0.95 * 1.0 + 0.05 * 0.95 * 1.5 + 0.0025 * 0.95 * 2.0, 1e-12);
  EXPECT_NEAR(r.alpha[c], 1 - 1.25e-4, 1e-12);
}

void ExpectSameBits(const std::vector<float>& a, const std::vector<float>& b, const char* what) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(float))) << what;
}

TEST(Rasterizer, IdenticalOutputForOneAndTwoThreads) {
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    Scene<float> s = RandomScene<float>(3000, 4, 31, 1.0, 6.0, 0.01, 0.2);
    const RasterCamera cam = MakeCamera(160, 120, 140.0);
    RasterSettings set;
    set.mode = mode;
    std::vector<float> vc(160 * 120 * 3), vd(160 * 120), va(160 * 120);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1, 1);
    for (float& v : vc) v = u(rng);
    for (float& v : vd) v = u(rng);
    for (float& v : va) v = u(rng);
    std::vector<Render<float>> renders;
    std::vector<Grads<float>> grads;
    for (int threads : {1, 2}) {
      set.num_threads = threads;
      renders.emplace_back(160, 120, s.n);
      auto st = cpu::Forward<float>(s.params(), cam, set, renders.back().outputs());
      grads.emplace_back(s);
      cpu::Backward<float>(*st, s.params(), cam, set, {vc.data(), vd.data(), va.data()}, grads.back().grads());
    }
    ExpectSameBits(renders[0].color, renders[1].color, "color");
    ExpectSameBits(renders[0].depth, renders[1].depth, "depth");
    ExpectSameBits(renders[0].alpha, renders[1].alpha, "alpha");
    ExpectSameBits(grads[0].means, grads[1].means, "v_means");
    ExpectSameBits(grads[0].log_scales, grads[1].log_scales, "v_log_scales");
    ExpectSameBits(grads[0].quats, grads[1].quats, "v_quats");
    ExpectSameBits(grads[0].opacity_logits, grads[1].opacity_logits, "v_opacity");
    ExpectSameBits(grads[0].sh, grads[1].sh, "v_sh");
    ExpectSameBits(grads[0].twist, grads[1].twist, "v_twist");
    ExpectSameBits(grads[0].mean2d_abs, grads[1].mean2d_abs, "v_mean2d_abs");
  }
}

// ---------------------------------------------------------------------------
// Bad input

TEST(Rasterizer, CulledGaussiansAreSkippedAndCounted) {
  Scene<float> s = RandomScene<float>(6, 1, 41);
  const float inf = std::numeric_limits<float>::infinity();
  s.means[2] = -2.0f;                                        // 0: behind the camera
  s.log_scales[3 * 1] = -inf;                                // 1: zero scale (log 0)
  s.opacity_logits[2] = -inf;                                // 2: zero opacity
  s.means[3 * 3 + 1] = std::numeric_limits<float>::quiet_NaN();  // 3: NaN mean
  s.sh[3 * 4] = inf;                                         // 4: infinite colour
  s.log_scales[3 * 5] = s.log_scales[3 * 5 + 1] = s.log_scales[3 * 5 + 2] = -30.0f;  // 5: degenerate, tiny
  const RasterCamera cam = MakeCamera(64, 48, 60.0);
  RasterSettings set;
  Render<float> r(64, 48, s.n);
  auto rasterizer = CreateRasterizer(Backend::kCpu);
  auto st = rasterizer->Forward(s.params(), cam, set, r.outputs());
  EXPECT_EQ(st->stats().num_nonfinite, 4);  // -inf scale, -inf logit, NaN, inf
  for (int i = 0; i < 5; ++i) EXPECT_EQ(r.radii[i], 0) << i;
  for (float v : r.color) ASSERT_TRUE(std::isfinite(v));
  for (float v : r.depth) ASSERT_TRUE(std::isfinite(v));
  std::vector<float> vc(64 * 48 * 3, 1.0f);
  Grads<float> g(s);
  rasterizer->Backward(*st, s.params(), cam, set, {vc.data(), nullptr, nullptr}, g.grads());
  for (float v : g.means) ASSERT_TRUE(std::isfinite(v));
  for (int k = 0; k < 3; ++k) EXPECT_EQ(g.means[3 * 3 + k], 0.0f);
  for (float v : g.twist) ASSERT_TRUE(std::isfinite(v));
}

TEST(Rasterizer, EmptySetRendersBackground) {
  Scene<float> s;
  const RasterCamera cam = MakeCamera(20, 10, 20.0);
  RasterSettings set;
  set.background[0] = 0.25f;
  set.background[1] = 0.5f;
  set.background[2] = 0.75f;
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    set.mode = mode;
    Render<float> r(20, 10, 0);
    auto st = CreateRasterizer(Backend::kCpu)->Forward(s.params(), cam, set, r.outputs());
    for (size_t i = 0; i < r.alpha.size(); ++i) {
      EXPECT_EQ(r.alpha[i], 0.0f);
      EXPECT_EQ(r.depth[i], 0.0f);
      EXPECT_EQ(r.color[3 * i + 2], 0.75f);
    }
    EXPECT_EQ(st->stats().num_visible, 0);
  }
}

TEST(Rasterizer, BadCameraSettingsAndShapesAreClearErrors) {
  Scene<float> s = RandomScene<float>(4, 1, 51);
  RasterSettings set;
  auto rasterizer = CreateRasterizer(Backend::kCpu);
  auto expect_error = [&](const RasterCamera& cam, const RasterSettings& st, const Scene<float>& sc,
                          const std::string& needle) {
    Render<float> r(std::max(cam.width, 1), std::max(cam.height, 1), sc.n);
    try {
      rasterizer->Forward(sc.params(), cam, st, r.outputs());
      ADD_FAILURE() << "no error for " << needle;
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  RasterCamera cam = MakeCamera(32, 24, 30.0);
  RasterCamera zero = cam;
  zero.width = 0;
  expect_error(zero, set, s, "image size");
  RasterCamera bad_f = cam;
  bad_f.fx = std::nan("");
  expect_error(bad_f, set, s, "fx");
  RasterCamera bad_pose = cam;
  bad_pose.cam_from_world[3] = std::numeric_limits<double>::infinity();
  expect_error(bad_pose, set, s, "cam_from_world[3]");
  RasterSettings bad_deg = set;
  bad_deg.sh_degree = 4;
  expect_error(cam, bad_deg, s, "sh_degree");
  RasterSettings bad_near = set;
  bad_near.near_plane = 0;
  expect_error(cam, bad_near, s, "near_plane");
  Scene<float> bad_k = s;
  bad_k.sh_coeffs = 5;
  expect_error(cam, set, bad_k, "sh_coeffs");
  Scene<float> null_means = s;
  null_means.means.clear();
  null_means.means.shrink_to_fit();
  expect_error(cam, set, null_means, "null");
}

TEST(Rasterizer, BackwardRejectsMismatchedState) {
  Scene<float> s = RandomScene<float>(4, 1, 61);
  const RasterCamera cam = MakeCamera(32, 24, 30.0);
  RasterSettings set;
  auto rasterizer = CreateRasterizer(Backend::kCpu);
  Render<float> r(32, 24, s.n);
  auto st = rasterizer->Forward(s.params(), cam, set, r.outputs());
  Scene<float> other = RandomScene<float>(5, 1, 62);
  Grads<float> g(other);
  EXPECT_THROW(rasterizer->Backward(*st, other.params(), cam, set, {}, g.grads()), InvalidInput);
  RasterSettings oit = set;
  oit.mode = CompositeMode::kOrderIndependent;
  Grads<float> g2(s);
  EXPECT_THROW(rasterizer->Backward(*st, s.params(), cam, oit, {}, g2.grads()), InvalidInput);
}

TEST(Rasterizer, CudaRequestWithoutCudaSaysWhy) {
  std::string why;
  if (BackendAvailable(Backend::kCuda, &why)) GTEST_SKIP() << "a CUDA device is present";
  EXPECT_FALSE(why.empty());
  try {
    CreateRasterizer(Backend::kCuda);
    ADD_FAILURE() << "expected an error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("CUDA"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dypho::kernels
