// The rasterizer benchmark in CUDA mode (issue 22): the "simple trainer"
// scene of rasterizer_bench.cc (N Gaussians, means uniform in [-1, 1]^3,
// linear scales uniform in [0, 1), random rotations, opacity sigmoid(1),
// uniform colours, camera 8 units away with a 90 degree horizontal field of
// view) with N = 10k, 100k, 1M at 640x480 and 1920x1080, forward and
// forward+backward, sorted mode (and order-independent at 640x480 for 10k
// and 100k, beside the CPU figures of rasterizer_bench).
//
//   build/tests/bench/rasterizer_cuda_bench --benchmark_filter=/1000000/
//
// All buffers live on the device; every iteration ends with a device
// synchronisation, so the time is the wall time of the whole render.
// Counters: visible, pairs = (Gaussian, tile) pairs, peak_pool_mb = the
// high-water mark of the device memory pool during the benchmark (every
// buffer of the rasterizer, scene and outputs included; -1 when the
// stream-ordered allocator is not in use), gpu_used_mb = the device memory in
// use after the run as cudaMemGetInfo reports it (CUDA context included).
// Without a CUDA device (or in a build without the CUDA backend) every case
// is reported as an error saying why.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "kernels/rasterizer.h"
#if defined(DYPHO_WITH_CUDA)
#include <cuda_runtime_api.h>

#include "kernels/cuda/device_array.h"
#endif

namespace {

using namespace dypho::kernels;

struct HostScene {
  std::vector<float> means, log_scales, quats, logits, sh;
  int n;
  explicit HostScene(int count) : n(count) {
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) means.push_back(2.0f * u(rng) - 1.0f);
      for (int k = 0; k < 3; ++k) log_scales.push_back(std::log(std::max(u(rng), 1e-6f)));
      const float u1 = u(rng), u2 = u(rng), u3 = u(rng);  // uniform rotation (Shoemake 1992)
      const float a = std::sqrt(1 - u1), b = std::sqrt(u1);
      quats.push_back(a * std::sin(2 * float(M_PI) * u2));
      quats.push_back(a * std::cos(2 * float(M_PI) * u2));
      quats.push_back(b * std::sin(2 * float(M_PI) * u3));
      quats.push_back(b * std::cos(2 * float(M_PI) * u3));
      logits.push_back(1.0f);
      for (int c = 0; c < 3; ++c) sh.push_back((u(rng) - 0.5f) / 0.28209479177387814f);
    }
  }
};

RasterCamera BenchCamera(int width, int height) {
  RasterCamera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.5 * width / std::tan(0.25 * M_PI);
  c.cx = 0.5 * width - 0.5;
  c.cy = 0.5 * height - 0.5;
  c.cam_from_world[11] = 8.0;
  return c;
}

#if defined(DYPHO_WITH_CUDA)
using dypho::kernels::cuda::DeviceArray;

// Args: {N, width, height, mode (0 sorted, 1 order-independent)}
void Run(benchmark::State& state, bool backward) {
  std::string why;
  if (!BackendAvailable(Backend::kCuda, &why)) {
    state.SkipWithError(("no GPU: " + why).c_str());
    return;
  }
  const int n = static_cast<int>(state.range(0));
  const RasterCamera cam = BenchCamera(static_cast<int>(state.range(1)), static_cast<int>(state.range(2)));
  RasterSettings settings;
  settings.mode = state.range(3) ? CompositeMode::kOrderIndependent : CompositeMode::kSorted;
  dypho::kernels::cuda::DeviceSynchronize();
  dypho::kernels::cuda::DevicePoolPeakBytes(/*reset=*/true);
  const HostScene host(n);
  const DeviceArray<float> means(host.means), log_scales(host.log_scales), quats(host.quats), logits(host.logits),
      sh(host.sh);
  GaussianParams params;
  params.means = means.data();
  params.log_scales = log_scales.data();
  params.quats = quats.data();
  params.opacity_logits = logits.data();
  params.sh = sh.data();
  params.num_gaussians = n;
  params.sh_coeffs = 1;
  const size_t pixels = static_cast<size_t>(cam.width) * cam.height;
  DeviceArray<float> color(3 * pixels), depth(pixels), alpha(pixels);
  DeviceArray<int32_t> radii(n);
  const DeviceArray<float> v_color(std::vector<float>(3 * pixels, 1e-3f)), v_depth(std::vector<float>(pixels, 1e-4f));
  DeviceArray<float> g_means(3 * n), g_ls(3 * n), g_q(4 * n), g_o(n), g_sh(3 * n), g_abs(n), g_twist(6);
  auto rasterizer = CreateRasterizer(Backend::kCuda);
  RasterStats stats;
  for (auto _ : state) {
    auto st = rasterizer->Forward(params, cam, settings, {color.data(), depth.data(), alpha.data(), radii.data()});
    if (backward) {
      rasterizer->Backward(*st, params, cam, settings, {v_color.data(), v_depth.data(), nullptr},
                           {g_means.data(), g_ls.data(), g_q.data(), g_o.data(), g_sh.data(), g_twist.data(),
                            g_abs.data()});
    }
    dypho::kernels::cuda::DeviceSynchronize();
    stats = st->stats();
  }
  const long long peak = dypho::kernels::cuda::DevicePoolPeakBytes(/*reset=*/true);
  size_t free_bytes = 0, total_bytes = 0;
  cudaMemGetInfo(&free_bytes, &total_bytes);
  state.counters["visible"] = stats.num_visible;
  state.counters["pairs"] = static_cast<double>(stats.num_tile_pairs);
  state.counters["peak_pool_mb"] = peak < 0 ? -1.0 : peak / 1048576.0;
  state.counters["gpu_used_mb"] = (total_bytes - free_bytes) / 1048576.0;
}
#else
void Run(benchmark::State& state, bool) {
  state.SkipWithError("no GPU: this build has no CUDA backend (nvcc was not found at configure time)");
}
#endif

void BM_CudaForward(benchmark::State& state) { Run(state, false); }
void BM_CudaForwardBackward(benchmark::State& state) { Run(state, true); }

void Cases(benchmark::internal::Benchmark* b) {
  for (int n : {10000, 100000, 1000000}) {
    b->Args({n, 640, 480, 0});
    b->Args({n, 1920, 1080, 0});
  }
  b->Args({10000, 640, 480, 1});
  b->Args({100000, 640, 480, 1});
  b->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(0.3);
}

BENCHMARK(BM_CudaForward)->Apply(Cases);
BENCHMARK(BM_CudaForwardBackward)->Apply(Cases);

}  // namespace

BENCHMARK_MAIN();
