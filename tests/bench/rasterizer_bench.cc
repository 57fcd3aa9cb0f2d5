// Rasterizer benchmark on the "simple trainer" scene (issue 2): N Gaussians
// with means uniform in [-1, 1]^3, linear scales uniform in [0, 1), uniformly
// random rotations, opacity sigmoid(1), uniform colours; camera 8 units from
// the cube's centre looking at it, 90 degree horizontal field of view, 640x480.
//
//   build/tests/bench/rasterizer_bench --benchmark_filter=/100000/0/
//
// Time is wall time; the CPU column is the whole process's CPU time (all
// threads), so CPU / wall shows how much of the two cores a run got on a
// shared machine. Counters: evals = Gaussian-pixel evaluations in the forward
// pass (RasterStats::num_evaluations: pixels inside a Gaussian's enlarged
// ellipse that had not terminated when it was composited); evals_per_s per
// wall second; pairs = (Gaussian, tile) pairs; peak_rss_mb = the process's
// peak resident memory so far.
#include <sys/resource.h>

#include <cmath>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "kernels/rasterizer.h"

namespace {

using namespace dypho::kernels;

struct SimpleTrainerScene {
  std::vector<float> means, log_scales, quats, logits, sh;
  int n;
  explicit SimpleTrainerScene(int count) : n(count) {
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) means.push_back(2.0f * u(rng) - 1.0f);
      for (int k = 0; k < 3; ++k) log_scales.push_back(std::log(std::max(u(rng), 1e-6f)));
      // Uniform random rotation (Shoemake 1992).
      const float u1 = u(rng), u2 = u(rng), u3 = u(rng);
      const float a = std::sqrt(1 - u1), b = std::sqrt(u1);
      quats.push_back(a * std::sin(2 * float(M_PI) * u2));
      quats.push_back(a * std::cos(2 * float(M_PI) * u2));
      quats.push_back(b * std::sin(2 * float(M_PI) * u3));
      quats.push_back(b * std::cos(2 * float(M_PI) * u3));
      logits.push_back(1.0f);
      for (int c = 0; c < 3; ++c) sh.push_back((u(rng) - 0.5f) / 0.28209479177387814f);
    }
  }
  GaussianParams params() const {
    GaussianParams p;
    p.means = means.data();
    p.log_scales = log_scales.data();
    p.quats = quats.data();
    p.opacity_logits = logits.data();
    p.sh = sh.data();
    p.num_gaussians = n;
    p.sh_coeffs = 1;
    return p;
  }
};

RasterCamera BenchCamera() {
  RasterCamera c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 0.5 * 640 / std::tan(0.25 * M_PI);
  c.cx = 319.5;
  c.cy = 239.5;
  c.cam_from_world[11] = 8.0;  // the cube's centre is 8 units ahead
  return c;
}

double PeakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;
}

const SimpleTrainerScene& Scene(int n) {
  static std::vector<std::unique_ptr<SimpleTrainerScene>> cache;
  for (auto& s : cache) {
    if (s->n == n) return *s;
  }
  cache.push_back(std::make_unique<SimpleTrainerScene>(n));
  return *cache.back();
}

void Run(benchmark::State& state, bool backward) {
  const int n = static_cast<int>(state.range(0));
  const CompositeMode mode = state.range(1) ? CompositeMode::kOrderIndependent : CompositeMode::kSorted;
  const SimpleTrainerScene& scene = Scene(n);
  const RasterCamera cam = BenchCamera();
  RasterSettings settings;
  settings.mode = mode;
  settings.num_threads = static_cast<int>(state.range(2));
  const size_t pixels = 640 * 480;
  std::vector<float> color(pixels * 3), depth(pixels), alpha(pixels);
  std::vector<int32_t> radii(n);
  std::vector<float> v_color(pixels * 3, 1e-3f), v_depth(pixels, 1e-4f);
  std::vector<float> g_means(3 * n), g_ls(3 * n), g_q(4 * n), g_o(n), g_sh(3 * n), g_abs(n), g_twist(6);
  auto rasterizer = CreateRasterizer(Backend::kCpu);
  RasterStats stats;
  for (auto _ : state) {
    auto st = rasterizer->Forward(scene.params(), cam, settings, {color.data(), depth.data(), alpha.data(), radii.data()});
    if (backward) {
      rasterizer->Backward(*st, scene.params(), cam, settings, {v_color.data(), v_depth.data(), nullptr},
                           {g_means.data(), g_ls.data(), g_q.data(), g_o.data(), g_sh.data(), g_twist.data(),
                            g_abs.data()});
    }
    stats = st->stats();
    benchmark::DoNotOptimize(color.data());
  }
  state.counters["visible"] = stats.num_visible;
  state.counters["pairs"] = static_cast<double>(stats.num_tile_pairs);
  state.counters["evals"] = static_cast<double>(stats.num_evaluations);
  state.counters["evals_per_s"] =
      benchmark::Counter(static_cast<double>(stats.num_evaluations), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["peak_rss_mb"] = PeakRssMb();
}

void BM_Forward(benchmark::State& state) { Run(state, false); }
void BM_ForwardBackward(benchmark::State& state) { Run(state, true); }

// Args: {N, mode (0 sorted, 1 order-independent), threads}
#define DYPHO_RASTER_ARGS                                                                            \
  ->Args({100000, 0, 2})->Args({100000, 1, 2})->Args({10000, 0, 2})->Args({10000, 1, 2})             \
      ->Args({300000, 0, 2})->Args({300000, 1, 2})->Args({100000, 0, 1})->Unit(benchmark::kMillisecond) \
      ->MeasureProcessCPUTime()->UseRealTime()

BENCHMARK(BM_Forward) DYPHO_RASTER_ARGS;
BENCHMARK(BM_ForwardBackward) DYPHO_RASTER_ARGS;

}  // namespace

BENCHMARK_MAIN();
