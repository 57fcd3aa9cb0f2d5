// Speed of map export and import (engine/export) for a 100k-Gaussian map
// with SH degree 3 (random values):
//
//   BM_SavePly / BM_LoadPly   3DGS PLY, 248 bytes per Gaussian
//   BM_SaveSplat              .splat (sort + quantise), 32 bytes per Gaussian
//   BM_SaveGlb                glTF binary with KHR_gaussian_splatting
//   BM_NeighbourDistances     k = 16 nearest-neighbour mean distances (the
//                             statistical outlier filter's cost), 100k points
//   BM_VoxelGrid              voxel-grid downsampling, 100k points, 2 cm cells
//
// Files go to a folder under the system's temporary directory, removed
// afterwards. Counter: Gaussians (or points) per second.
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "engine/export/gltf.h"
#include "engine/export/ply.h"
#include "engine/export/point_cloud.h"
#include "engine/export/splat.h"

namespace {

constexpr int kGaussians = 100000;

const dypho::GaussianCloud& BenchCloud() {
  static const dypho::GaussianCloud cloud = [] {
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    dypho::GaussianCloud c;
    c.sh_coeffs = 16;
    std::vector<float> coeffs(48);
    for (int i = 0; i < kGaussians; ++i) {
      const float mean[3] = {2 * u(rng), u(rng), 3 + u(rng)};
      const float log_scale[3] = {u(rng) - 4, u(rng) - 4, u(rng) - 4};
      const float quat[4] = {u(rng), u(rng), u(rng), u(rng) + 2};
      for (float& v : coeffs) v = u(rng);
      c.Add(mean, log_scale, quat, 3 * u(rng), coeffs.data());
    }
    return c;
  }();
  return cloud;
}

std::string BenchDir() {
  const auto dir = std::filesystem::temp_directory_path() / "dypho_export_bench";
  std::filesystem::create_directories(dir);
  return dir.string();
}

void SetRate(benchmark::State& state, int items) {
  state.counters["items_per_s"] =
      benchmark::Counter(static_cast<double>(items) * state.iterations(), benchmark::Counter::kIsRate);
}

void BM_SavePly(benchmark::State& state) {
  const auto& cloud = BenchCloud();
  const std::string path = BenchDir() + "/map.ply";
  for (auto _ : state) dypho::SavePly(cloud, path);
  SetRate(state, cloud.size());
}

void BM_LoadPly(benchmark::State& state) {
  const std::string path = BenchDir() + "/load.ply";
  dypho::SavePly(BenchCloud(), path);
  for (auto _ : state) benchmark::DoNotOptimize(dypho::LoadPly(path).size());
  SetRate(state, kGaussians);
}

void BM_SaveSplat(benchmark::State& state) {
  const auto& cloud = BenchCloud();
  const std::string path = BenchDir() + "/map.splat";
  for (auto _ : state) dypho::SaveSplat(cloud, path);
  SetRate(state, cloud.size());
}

void BM_SaveGlb(benchmark::State& state) {
  const auto& cloud = BenchCloud();
  const std::string path = BenchDir() + "/map.glb";
  for (auto _ : state) dypho::SaveGltf(cloud, path);
  SetRate(state, cloud.size());
}

void BM_NeighbourDistances(benchmark::State& state) {
  const dypho::ColoredPoints points = dypho::PointsFromGaussians(BenchCloud());
  for (auto _ : state) benchmark::DoNotOptimize(dypho::MeanNeighborDistances(points, 16).data());
  SetRate(state, points.size());
}

void BM_VoxelGrid(benchmark::State& state) {
  const dypho::ColoredPoints points = dypho::PointsFromGaussians(BenchCloud());
  for (auto _ : state) benchmark::DoNotOptimize(dypho::VoxelGridDownsample(points, 0.02).size());
  SetRate(state, points.size());
}

BENCHMARK(BM_SavePly)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_LoadPly)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SaveSplat)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SaveGlb)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_NeighbourDistances)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_VoxelGrid)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::filesystem::remove_all(std::filesystem::temp_directory_path() / "dypho_export_bench");
  return 0;
}
