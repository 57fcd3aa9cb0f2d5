// CUDA vs CPU parity of the rasterizer: outputs, statistics and gradients for
// a random cotangent, in both compositing modes and for SH degrees 0..3,
// including batches of more than 256 Gaussians per tile, early termination,
// culled and non-finite Gaussians, empty scenes, null cotangents, 16 random
// scenes of random size and large scenes (100k at 640x480, 300k at 1080p).
//
// Skipped (with the reason) where the CUDA backend is not usable: a build
// without nvcc, or no device. The device-memory part is compiled only when
// this test is built with DYPHO_WITH_CUDA (tests/CMakeLists.txt defines it
// when the CUDA backend is built); a test built without it fails if a device
// is present, since it could not check the backend it has.
//
// Tolerances. Both backends run the same float math (kernels/math), but nvcc
// contracts a * b + c into fused multiply-adds and the backward pass sums with
// atomics in no fixed order, so results differ in the last bits. Those bits
// can flip a per-pixel threshold (alpha >= 1/255 at the footprint's edge,
// T >= 1e-4 in sorted mode) for a rare (Gaussian, pixel), which changes that
// pixel by up to ~1e-2 and the gradients of a few Gaussians by ~1%. Hence:
// - images: |cpu - cuda| <= 1e-4 (colour, alpha) and 5e-4 (depth, ~3 m) for
//   all but 0.5% of the pixels, and <= 5e-2 everywhere;
// - gradients: |cpu - cuda| <= 1e-3 |cpu| + 1e-4 max|cpu| per element for
//   all but 0.5% of the elements (at least 2 allowed), <= 5e-2 max|cpu|
//   everywhere, and a relative L2 error <= 1e-3 per array;
// - the pose gradient: |cpu - cuda| <= 2e-3 |cpu| (vector norms).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/check.h"
#include "common/rigid3.h"
#include "kernels/rasterizer.h"
#include "tests/raster_scene.h"
#if defined(DYPHO_WITH_CUDA)
#include "kernels/cuda/cuda_rasterizer.h"
#endif

namespace dypho::kernels {
namespace {

using testing::MakeCamera;
using testing::RandomScene;
using testing::Scene;

// Cotangents of the outputs; an empty vector is passed as a null pointer.
struct Cotangents {
  std::vector<float> v_color, v_depth, v_alpha;
};

Cotangents RandomCotangents(const RasterCamera& cam, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  const size_t pixels = static_cast<size_t>(cam.width) * cam.height;
  Cotangents c;
  c.v_color.resize(3 * pixels);
  c.v_depth.resize(pixels);
  c.v_alpha.resize(pixels);
  for (float& v : c.v_color) v = u(rng);
  for (float& v : c.v_depth) v = 0.3f * u(rng);
  for (float& v : c.v_alpha) v = u(rng);
  return c;
}

// Everything one backend produced, on the host.
struct Result {
  std::vector<float> color, depth, alpha;
  std::vector<int32_t> radii;
  RasterStats stats;
  std::vector<float> v_means, v_log_scales, v_quats, v_logits, v_sh, v_twist, v_mean2d_abs;
};

const float kNaN = std::numeric_limits<float>::quiet_NaN();

// Gradient buffers start as NaN: Backward must overwrite every entry.
Result RunCpu(const Scene<float>& s, const RasterCamera& cam, const RasterSettings& set, const Cotangents& cot) {
  const size_t pixels = static_cast<size_t>(cam.width) * cam.height;
  const size_t n = static_cast<size_t>(s.n);
  Result r;
  r.color.assign(3 * pixels, kNaN);
  r.depth.assign(pixels, kNaN);
  r.alpha.assign(pixels, kNaN);
  r.radii.assign(n, -1);
  auto rasterizer = CreateRasterizer(Backend::kCpu);
  auto state =
      rasterizer->Forward(s.params(), cam, set, {r.color.data(), r.depth.data(), r.alpha.data(), r.radii.data()});
  r.stats = state->stats();
  r.v_means.assign(3 * n, kNaN);
  r.v_log_scales.assign(3 * n, kNaN);
  r.v_quats.assign(4 * n, kNaN);
  r.v_logits.assign(n, kNaN);
  r.v_sh.assign(3 * s.sh_coeffs * n, kNaN);
  r.v_twist.assign(6, kNaN);
  r.v_mean2d_abs.assign(n, kNaN);
  auto or_null = [](const std::vector<float>& v) { return v.empty() ? nullptr : v.data(); };
  const RasterOutputGrads og{or_null(cot.v_color), or_null(cot.v_depth), or_null(cot.v_alpha)};
  const GaussianGrads gg{r.v_means.data(), r.v_log_scales.data(), r.v_quats.data(),     r.v_logits.data(),
                         r.v_sh.data(),    r.v_twist.data(),      r.v_mean2d_abs.data()};
  rasterizer->Backward(*state, s.params(), cam, set, og, gg);
  return r;
}

#if defined(DYPHO_WITH_CUDA)
using cuda::DeviceArray;

Result RunCuda(const Scene<float>& s, const RasterCamera& cam, const RasterSettings& set, const Cotangents& cot) {
  const size_t pixels = static_cast<size_t>(cam.width) * cam.height;
  const size_t n = static_cast<size_t>(s.n);
  const DeviceArray<float> means(s.means), log_scales(s.log_scales), quats(s.quats), logits(s.opacity_logits),
      sh(s.sh);
  GaussianParams params;
  params.means = means.data();
  params.log_scales = log_scales.data();
  params.quats = quats.data();
  params.opacity_logits = logits.data();
  params.sh = sh.data();
  params.num_gaussians = s.n;
  params.sh_coeffs = s.sh_coeffs;

  DeviceArray<float> color(std::vector<float>(3 * pixels, kNaN)), depth(std::vector<float>(pixels, kNaN)),
      alpha(std::vector<float>(pixels, kNaN));
  DeviceArray<int32_t> radii(std::vector<int32_t>(n, -1));
  auto rasterizer = CreateRasterizer(Backend::kCuda);
  EXPECT_EQ(rasterizer->backend(), Backend::kCuda);
  auto state = rasterizer->Forward(params, cam, set, {color.data(), depth.data(), alpha.data(), radii.data()});
  Result r;
  r.color = color.ToHost();
  r.depth = depth.ToHost();
  r.alpha = alpha.ToHost();
  r.radii = radii.ToHost();
  r.stats = state->stats();

  const DeviceArray<float> v_color(cot.v_color), v_depth(cot.v_depth), v_alpha(cot.v_alpha);
  DeviceArray<float> g_means(std::vector<float>(3 * n, kNaN)), g_log_scales(std::vector<float>(3 * n, kNaN)),
      g_quats(std::vector<float>(4 * n, kNaN)), g_logits(std::vector<float>(n, kNaN)),
      g_sh(std::vector<float>(3 * s.sh_coeffs * n, kNaN)), g_twist(std::vector<float>(6, kNaN)),
      g_mean2d_abs(std::vector<float>(n, kNaN));
  const RasterOutputGrads og{v_color.data(), v_depth.data(), v_alpha.data()};  // empty -> null
  const GaussianGrads gg{g_means.data(), g_log_scales.data(), g_quats.data(),     g_logits.data(),
                         g_sh.data(),    g_twist.data(),      g_mean2d_abs.data()};
  rasterizer->Backward(*state, params, cam, set, og, gg);
  r.v_means = g_means.ToHost();
  r.v_log_scales = g_log_scales.ToHost();
  r.v_quats = g_quats.ToHost();
  r.v_logits = g_logits.ToHost();
  r.v_sh = g_sh.ToHost();
  r.v_twist = g_twist.ToHost();
  r.v_mean2d_abs = g_mean2d_abs.ToHost();
  cuda::DeviceSynchronize();
  return r;
}
#else
Result RunCuda(const Scene<float>&, const RasterCamera&, const RasterSettings&, const Cotangents&) {
  ADD_FAILURE() << "cuda_parity_test was built without DYPHO_WITH_CUDA";
  return {};
}
#endif

// ---------------------------------------------------------------------------
// Comparisons

::testing::AssertionResult ImagesClose(const char* what, const std::vector<float>& cpu,
                                       const std::vector<float>& gpu, float tol) {
  constexpr double kMaxOutlierFraction = 0.005;
  constexpr float kMaxError = 5e-2f;
  if (cpu.size() != gpu.size()) {
    return ::testing::AssertionFailure() << what << ": sizes " << cpu.size() << " vs " << gpu.size();
  }
  size_t outliers = 0, worst = 0;
  float worst_error = 0.f;
  for (size_t i = 0; i < cpu.size(); ++i) {
    const float e = std::fabs(cpu[i] - gpu[i]);
    if (!(e <= tol)) ++outliers;  // NaN counts
    if (!(e <= worst_error)) {
      worst_error = e;
      worst = i;
    }
  }
  const size_t allowed = static_cast<size_t>(kMaxOutlierFraction * cpu.size());
  if (outliers > allowed || !(worst_error <= kMaxError)) {
    return ::testing::AssertionFailure()
           << what << ": " << outliers << " of " << cpu.size() << " values differ by more than " << tol
           << " (allowed " << allowed << "); worst at " << worst << ": cpu " << cpu[worst] << " vs cuda "
           << gpu[worst];
  }
  return ::testing::AssertionSuccess();
}

::testing::AssertionResult GradsClose(const char* what, const std::vector<float>& cpu,
                                      const std::vector<float>& gpu) {
  constexpr double kRtol = 1e-3;
  constexpr double kAtolOfMax = 1e-4;
  constexpr double kMaxOutlierFraction = 0.005;
  constexpr double kMaxErrorOfMax = 5e-2;
  constexpr double kMaxRelativeL2 = 1e-3;
  if (cpu.size() != gpu.size()) {
    return ::testing::AssertionFailure() << what << ": sizes " << cpu.size() << " vs " << gpu.size();
  }
  double scale = 0.0, norm2 = 0.0, diff2 = 0.0;
  for (size_t i = 0; i < cpu.size(); ++i) {
    if (!std::isfinite(cpu[i]) || !std::isfinite(gpu[i])) {
      return ::testing::AssertionFailure()
             << what << "[" << i << "] is not finite: cpu " << cpu[i] << " vs cuda " << gpu[i];
    }
    scale = std::max(scale, std::fabs(double(cpu[i])));
    norm2 += double(cpu[i]) * cpu[i];
    diff2 += (double(cpu[i]) - gpu[i]) * (double(cpu[i]) - gpu[i]);
  }
  size_t outliers = 0, worst = 0;
  double worst_error = 0.0;
  for (size_t i = 0; i < cpu.size(); ++i) {
    const double e = std::fabs(double(cpu[i]) - gpu[i]);
    if (e > kRtol * std::fabs(double(cpu[i])) + kAtolOfMax * scale) ++outliers;
    if (e > worst_error) {
      worst_error = e;
      worst = i;
    }
  }
  const size_t allowed = std::max<size_t>(2, static_cast<size_t>(kMaxOutlierFraction * cpu.size()));
  const double rel_l2 = norm2 > 0 ? std::sqrt(diff2 / norm2) : std::sqrt(diff2);
  if (outliers > allowed || worst_error > kMaxErrorOfMax * scale || rel_l2 > kMaxRelativeL2) {
    return ::testing::AssertionFailure()
           << what << ": " << outliers << " of " << cpu.size() << " elements outside tolerance (allowed "
           << allowed << "), relative L2 error " << rel_l2 << ", max |cpu| " << scale << "; worst at " << worst
           << ": cpu " << cpu[worst] << " vs cuda " << gpu[worst];
  }
  return ::testing::AssertionSuccess();
}

::testing::AssertionResult TwistClose(const std::vector<float>& cpu, const std::vector<float>& gpu) {
  double norm2 = 0.0, diff2 = 0.0;
  for (int i = 0; i < 6; ++i) {
    norm2 += double(cpu[i]) * cpu[i];
    diff2 += (double(cpu[i]) - gpu[i]) * (double(cpu[i]) - gpu[i]);
  }
  if (std::isfinite(diff2) && std::sqrt(diff2) <= 2e-3 * std::sqrt(norm2) + 1e-7) {
    return ::testing::AssertionSuccess();
  }
  std::ostringstream msg;
  msg << "v_cam_twist: cpu (";
  for (int i = 0; i < 6; ++i) msg << cpu[i] << (i < 5 ? ", " : ") vs cuda (");
  for (int i = 0; i < 6; ++i) msg << gpu[i] << (i < 5 ? ", " : ")");
  return ::testing::AssertionFailure() << msg.str();
}

void ExpectParity(const Result& cpu, const Result& gpu, bool check_grads = true) {
  EXPECT_TRUE(ImagesClose("color", cpu.color, gpu.color, 1e-4f));
  EXPECT_TRUE(ImagesClose("depth", cpu.depth, gpu.depth, 5e-4f));
  EXPECT_TRUE(ImagesClose("alpha", cpu.alpha, gpu.alpha, 1e-4f));

  EXPECT_EQ(cpu.stats.num_gaussians, gpu.stats.num_gaussians);
  EXPECT_EQ(cpu.stats.num_visible, gpu.stats.num_visible);
  EXPECT_EQ(cpu.stats.num_nonfinite, gpu.stats.num_nonfinite);
  // Same binning; a footprint at a tile border may round differently.
  EXPECT_LE(std::llabs(cpu.stats.num_tile_pairs - gpu.stats.num_tile_pairs), 2 + cpu.stats.num_tile_pairs / 200)
      << "cpu " << cpu.stats.num_tile_pairs << " vs cuda " << gpu.stats.num_tile_pairs;
  ASSERT_EQ(cpu.radii.size(), gpu.radii.size());
  size_t radius_mismatches = 0;
  for (size_t i = 0; i < cpu.radii.size(); ++i) {
    EXPECT_EQ(cpu.radii[i] > 0, gpu.radii[i] > 0) << "Gaussian " << i << " visible in one backend only";
    if (cpu.radii[i] != gpu.radii[i]) ++radius_mismatches;  // ceil() of a rounded value may differ by 1
  }
  EXPECT_LE(radius_mismatches, 1 + cpu.radii.size() / 100);

  if (!check_grads) return;
  EXPECT_TRUE(GradsClose("v_means", cpu.v_means, gpu.v_means));
  EXPECT_TRUE(GradsClose("v_log_scales", cpu.v_log_scales, gpu.v_log_scales));
  EXPECT_TRUE(GradsClose("v_quats", cpu.v_quats, gpu.v_quats));
  EXPECT_TRUE(GradsClose("v_opacity_logits", cpu.v_logits, gpu.v_logits));
  EXPECT_TRUE(GradsClose("v_sh", cpu.v_sh, gpu.v_sh));
  EXPECT_TRUE(GradsClose("v_mean2d_abs", cpu.v_mean2d_abs, gpu.v_mean2d_abs));
  ASSERT_EQ(gpu.v_twist.size(), 6u);
  EXPECT_TRUE(TwistClose(cpu.v_twist, gpu.v_twist));
}

// A camera a little off the identity, so every pose term is exercised.
RasterCamera PosedCamera(int width, int height, double f) {
  RasterCamera cam = MakeCamera(width, height, f);
  Eigen::Matrix<double, 6, 1> xi;
  xi << 0.05, -0.03, 0.1, 0.02, -0.03, 0.015;
  const Eigen::Matrix<double, 3, 4> m = Rigid3d::Exp(xi).ToMatrix();
  for (int i = 0; i < 12; ++i) cam.cam_from_world[i] = m(i / 4, i % 4);
  return cam;
}

RasterSettings Settings(CompositeMode mode, int sh_degree) {
  RasterSettings set;
  set.mode = mode;
  set.sh_degree = sh_degree;
  set.background[0] = 0.1f;
  set.background[1] = 0.3f;
  set.background[2] = 0.6f;
  return set;
}

// ---------------------------------------------------------------------------
// Tests

TEST(CudaBackend, AvailabilityHasAReason) {
  std::string why;
  if (BackendAvailable(Backend::kCuda, &why)) {
    EXPECT_EQ(CreateRasterizer(Backend::kCuda)->backend(), Backend::kCuda);
    return;
  }
  EXPECT_FALSE(why.empty());
  try {
    CreateRasterizer(Backend::kCuda);
    ADD_FAILURE() << "CreateRasterizer(kCuda) should throw without a usable CUDA backend";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
  }
  GTEST_SKIP() << "CUDA backend unavailable: " << why;
}

class CudaParityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (!BackendAvailable(Backend::kCuda, &why)) GTEST_SKIP() << "CUDA backend unavailable: " << why;
#if !defined(DYPHO_WITH_CUDA)
    FAIL() << "a CUDA device is available but cuda_parity_test was compiled without DYPHO_WITH_CUDA: add "
              "target_compile_definitions(cuda_parity_test PRIVATE DYPHO_WITH_CUDA=1) when DYPHO_HAVE_CUDA";
#endif
  }

  void CheckScene(const Scene<float>& scene, const RasterCamera& cam, const RasterSettings& set, unsigned seed,
                  const char* label) {
    SCOPED_TRACE(::testing::Message() << label << ", " << CompositeModeName(set.mode) << ", sh_degree "
                                      << set.sh_degree << ", sh_coeffs " << scene.sh_coeffs);
    const Cotangents cot = RandomCotangents(cam, seed);
    const Result cpu = RunCpu(scene, cam, set, cot);
    const Result gpu = RunCuda(scene, cam, set, cot);
    ExpectParity(cpu, gpu);
  }
};

// A few hundred Gaussians, every SH degree, both modes, an image size that is
// not a multiple of the tile size, a non-identity pose and a background.
TEST_F(CudaParityTest, RandomScenes) {
  const RasterCamera cam = PosedCamera(97, 75, 80.0);
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    for (int degree = 0; degree <= 3; ++degree) {
      const int coeffs = (degree + 1) * (degree + 1);
      const unsigned seed = 100u + 10u * degree + (mode == CompositeMode::kSorted ? 0u : 5u);
      const Scene<float> scene = RandomScene<float>(300, coeffs, seed);
      CheckScene(scene, cam, Settings(mode, degree), seed + 1, "random");
    }
  }
}

// Stored coefficients beyond the active degree: their gradients are zero.
TEST_F(CudaParityTest, ActiveDegreeBelowStored) {
  const RasterCamera cam = PosedCamera(64, 48, 60.0);
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    const Scene<float> scene = RandomScene<float>(200, 16, 7);
    CheckScene(scene, cam, Settings(mode, 1), 8, "sh 16 coeffs, degree 1");
  }
}

// Large, nearly opaque Gaussians: hundreds per tile (several shared-memory
// batches) and sorted-mode early termination in most pixels.
TEST_F(CudaParityTest, DenseOpaqueScene) {
  const RasterCamera cam = PosedCamera(64, 48, 60.0);
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    const Scene<float> scene = RandomScene<float>(700, 4, 21, 2.0, 4.0, 0.15, 0.4, 1.0, 4.0);
    CheckScene(scene, cam, Settings(mode, 1), 22, "dense");
  }
}

// Culled and non-finite Gaussians among visible ones, and one that covers
// the whole image.
TEST_F(CudaParityTest, CulledAndNonFiniteGaussians) {
  Scene<float> scene = RandomScene<float>(120, 4, 31);
  const std::vector<float> coeffs(12, 0.2f);
  const float q[4] = {1, 0, 0, 0};
  const float ls[3] = {-2, -2, -2};
  const float behind[3] = {0, 0, -3};
  scene.Add(behind, ls, q, 2.f, coeffs);  // behind the camera
  const float front[3] = {0.1f, 0.f, 3.f};
  scene.Add(front, ls, q, -10.f, coeffs);  // opacity below 1/255
  const float nan_mean[3] = {kNaN, 0.f, 3.f};
  scene.Add(nan_mean, ls, q, 1.f, coeffs);  // non-finite mean
  const float zero_q[4] = {0, 0, 0, 0};
  scene.Add(front, ls, zero_q, 1.f, coeffs);  // zero quaternion
  const float inf_ls[3] = {-std::numeric_limits<float>::infinity(), -2, -2};
  scene.Add(front, inf_ls, q, 1.f, coeffs);  // log(0) scale
  const float big_ls[3] = {0.f, 0.f, 0.f};
  const float centre[3] = {0.f, 0.f, 2.5f};
  scene.Add(centre, big_ls, q, 0.f, coeffs);  // covers the image
  const RasterCamera cam = PosedCamera(70, 50, 60.0);
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    const Cotangents cot = RandomCotangents(cam, 32);
    const Result cpu = RunCpu(scene, cam, Settings(mode, 1), cot);
    const Result gpu = RunCuda(scene, cam, Settings(mode, 1), cot);
    EXPECT_EQ(gpu.stats.num_nonfinite, 3);
    ExpectParity(cpu, gpu);
  }
}

// No Gaussians, and Gaussians that are all culled: the background, zero
// gradients (overwritten) and no pairs.
TEST_F(CudaParityTest, EmptyAndAllCulled) {
  const RasterCamera cam = PosedCamera(40, 30, 36.0);
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    const RasterSettings set = Settings(mode, 0);
    const Cotangents cot = RandomCotangents(cam, 41);
    Scene<float> empty;
    const Result gpu_empty = RunCuda(empty, cam, set, cot);
    ExpectParity(RunCpu(empty, cam, set, cot), gpu_empty);
    ASSERT_EQ(gpu_empty.color.size(), size_t(3 * 40 * 30));
    EXPECT_EQ(gpu_empty.color[0], set.background[0]);
    EXPECT_EQ(gpu_empty.alpha[0], 0.f);
    for (float v : gpu_empty.v_twist) EXPECT_EQ(v, 0.f);

    Scene<float> culled = RandomScene<float>(50, 1, 42, -4.0, -2.0);  // behind the camera
    const Result gpu = RunCuda(culled, cam, set, cot);
    ExpectParity(RunCpu(culled, cam, set, cot), gpu);
    EXPECT_EQ(gpu.stats.num_visible, 0);
    EXPECT_EQ(gpu.stats.num_tile_pairs, 0);
    for (float v : gpu.v_means) EXPECT_EQ(v, 0.f);
  }
}

// Null cotangents mean zero.
TEST_F(CudaParityTest, NullCotangents) {
  const RasterCamera cam = PosedCamera(64, 48, 60.0);
  const Scene<float> scene = RandomScene<float>(150, 4, 51);
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    Cotangents cot = RandomCotangents(cam, 52);
    cot.v_depth.clear();
    cot.v_alpha.clear();
    ExpectParity(RunCpu(scene, cam, Settings(mode, 1), cot), RunCuda(scene, cam, Settings(mode, 1), cot));
  }
}

// Many random scenes: sizes from 1 to 3000 Gaussians, image sizes from 1x1
// to 200x150, random poses, modes, SH degrees, backgrounds and scale ranges.
TEST_F(CudaParityTest, ManyRandomScenes) {
  std::mt19937 rng(2026);
  std::uniform_int_distribution<int> count(1, 3000), side(1, 200), degree_of(0, 3), mode_of(0, 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 16; ++trial) {
    const int degree = degree_of(rng);
    const int coeffs = (degree + 1) * (degree + 1);
    const int width = trial == 0 ? 1 : side(rng);
    const int height = trial == 0 ? 1 : std::max(1, width * 3 / 4);
    RasterCamera cam = PosedCamera(width, height, 0.8 * width + 1.0);
    const double scale_max = 0.02 + 0.3 * u(rng);
    const Scene<float> scene =
        RandomScene<float>(count(rng), coeffs, 500u + trial, 1.0, 6.0, 0.01, scale_max, -3.0, 4.0);
    RasterSettings set = Settings(mode_of(rng) ? CompositeMode::kOrderIndependent : CompositeMode::kSorted, degree);
    for (float& b : set.background) b = static_cast<float>(u(rng));
    const std::string label = "trial " + std::to_string(trial) + ", " + std::to_string(scene.n) + " Gaussians, " +
                              std::to_string(width) + "x" + std::to_string(height);
    CheckScene(scene, cam, set, 600u + trial, label.c_str());
  }
}

// Large scenes at the benchmark's resolutions: 100k Gaussians at 640x480
// (SH degree 3, both modes) and 300k at 1920x1080 (degree 1, sorted), small
// splats as in a trained map. The CPU reference runs on all cores.
TEST_F(CudaParityTest, LargeScenes) {
  const RasterCamera vga = PosedCamera(640, 480, 500.0);
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    const Scene<float> scene = RandomScene<float>(100000, 16, 71, 1.5, 6.0, 0.004, 0.04, -2.0, 3.0);
    CheckScene(scene, vga, Settings(mode, 3), 72, "100k at 640x480");
  }
  const RasterCamera hd = PosedCamera(1920, 1080, 1400.0);
  const Scene<float> scene = RandomScene<float>(300000, 4, 73, 1.5, 6.0, 0.003, 0.03, -2.0, 3.0);
  CheckScene(scene, hd, Settings(CompositeMode::kSorted, 1), 74, "300k at 1920x1080");
}

}  // namespace
}  // namespace dypho::kernels
