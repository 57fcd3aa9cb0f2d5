// Vulkan renderer (lavapipe or any device) beside the CPU reference
// rasterizer: frames per second at 1280x720, both compositing modes.
//
//   build/tests/bench/vulkan_bench
//
// Scenes (means uniform in [-1, 1]^3, uniformly random rotations, camera 8
// units from the cube's centre, 90 degree horizontal field of view, SH
// degree 0, uniform random colours):
//   scene 0: the rasterizer_bench "simple trainer" scene: linear scales
//            uniform in [0, 1), opacity sigmoid(1) (very large splats);
//   scene 1: gsplat simple_trainer's random initialisation: isotropic
//            scales = mean distance to the 3 nearest neighbours (its
//            expectation for N uniform points in the cube,
//            1.437 N^(-1/3)), opacity 0.1.
// Args: {N, mode (0 sorted, 1 order-independent), backend (0 CPU with 2
// threads, 1 Vulkan), scene}. A Vulkan frame includes the readback of
// colour, depth and alpha to host memory; the map is uploaded once.
// Counters: fps, visible Gaussians; for Vulkan the device time per stage
// (timestamp queries): project_ms, sort_ms, draw_ms, resolve_ms.
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <benchmark/benchmark.h>

#include "engine/gaussians.h"
#include "engine/render/render.h"
#include "engine/vulkan/vulkan_renderer.h"

namespace {

using namespace dypho;

GaussianCloud MakeScene(int n, int scene) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  GaussianCloud cloud;
  cloud.means.reserve(3 * n);
  const float knn_scale = 1.437f * std::pow(float(n), -1.0f / 3.0f);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) cloud.means.push_back(2.0f * u(rng) - 1.0f);
    for (int k = 0; k < 3; ++k) {
      cloud.log_scales.push_back(scene == 0 ? std::log(std::max(u(rng), 1e-6f)) : std::log(knn_scale));
    }
    const float u1 = u(rng), u2 = u(rng), u3 = u(rng);
    const float a = std::sqrt(1 - u1), b = std::sqrt(u1);
    cloud.quats.push_back(a * std::sin(2 * float(M_PI) * u2));
    cloud.quats.push_back(a * std::cos(2 * float(M_PI) * u2));
    cloud.quats.push_back(b * std::sin(2 * float(M_PI) * u3));
    cloud.quats.push_back(b * std::cos(2 * float(M_PI) * u3));
    cloud.opacity_logits.push_back(scene == 0 ? 1.0f : std::log(0.1f / 0.9f));
    for (int c = 0; c < 3; ++c) cloud.sh.push_back((u(rng) - 0.5f) / 0.28209479177387814f);
  }
  return cloud;
}

kernels::RasterCamera BenchCamera() {
  kernels::RasterCamera c;
  c.width = 1280;
  c.height = 720;
  c.fx = c.fy = 0.5 * 1280 / std::tan(0.25 * M_PI);
  c.cx = 639.5;
  c.cy = 359.5;
  c.cam_from_world[11] = 8.0;
  return c;
}

const GaussianCloud& Scene(int n, int scene) {
  static std::vector<std::pair<std::pair<int, int>, std::unique_ptr<GaussianCloud>>> cache;
  for (auto& s : cache) {
    if (s.first == std::make_pair(n, scene)) return *s.second;
  }
  cache.emplace_back(std::make_pair(n, scene), std::make_unique<GaussianCloud>(MakeScene(n, scene)));
  return *cache.back().second;
}

vulkan::VulkanRenderer& Gpu() {
  static std::unique_ptr<vulkan::VulkanRenderer> renderer = std::make_unique<vulkan::VulkanRenderer>();
  return *renderer;
}

void BM_Render(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const bool oit = state.range(1) != 0;
  const bool gpu = state.range(2) != 0;
  const GaussianCloud& cloud = Scene(n, static_cast<int>(state.range(3)));
  kernels::RasterSettings settings;
  settings.mode = oit ? kernels::CompositeMode::kOrderIndependent : kernels::CompositeMode::kSorted;
  settings.num_threads = 2;
  const kernels::RasterCamera cam = BenchCamera();
  std::unique_ptr<kernels::Rasterizer> cpu;
  std::vector<float> color(1280 * 720 * 3), depth(1280 * 720), alpha(1280 * 720);
  if (gpu) {
    Gpu().SetMap(cloud);
  } else {
    cpu = kernels::CreateRasterizer(kernels::Backend::kCpu);
  }
  int visible = 0;
  vulkan::VulkanRenderer::StageTimes stages;
  for (auto _ : state) {
    if (gpu) {
      const RenderedView v = Gpu().Render(cam, settings);
      visible = v.stats.num_visible;
      const auto t = Gpu().last_stage_times();
      stages.project += t.project / state.max_iterations;
      stages.sort += t.sort / state.max_iterations;
      stages.draw += t.draw / state.max_iterations;
      stages.resolve += t.resolve / state.max_iterations;
      benchmark::DoNotOptimize(v.color.data());
    } else {
      auto st = cpu->Forward(cloud.params(), cam, settings, {color.data(), depth.data(), alpha.data(), nullptr});
      visible = st->stats().num_visible;
      benchmark::DoNotOptimize(color.data());
    }
  }
  state.counters["fps"] = benchmark::Counter(1.0, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["visible"] = visible;
  if (gpu) {
    state.counters["project_ms"] = stages.project;
    state.counters["sort_ms"] = stages.sort;
    state.counters["draw_ms"] = stages.draw;
    state.counters["resolve_ms"] = stages.resolve;
  }
  state.SetLabel(std::string(gpu ? "vulkan " + Gpu().device_description() : "cpu 2 threads") +
                 (oit ? ", order-independent" : ", sorted"));
}

// Scene 0 is registered for the CPU's sorted mode only: on lavapipe its
// ~10^10 fragments per frame take minutes (a 3-frame run did not finish in
// 5 minutes); pass --benchmark_filter=BM_Render/100000/0/1/0 to try.
BENCHMARK(BM_Render)
    ->ArgsProduct({{100000, 1000000}, {0, 1}, {1, 0}, {1}})
    ->Args({100000, 0, 0, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
