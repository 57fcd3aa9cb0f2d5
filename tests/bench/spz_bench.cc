// Size and write time of a 300k-Gaussian map (SH degree 3, random values in
// the ranges of a real map) in .spz against .ply and .splat, and the .spz
// read time:
//
//   BM_SaveMapPly      3DGS PLY, 248 bytes per Gaussian, lossless
//   BM_SaveMapSplat    .splat, 32 bytes per Gaussian, degree-0 colour only
//   BM_SaveMapSpz/v    .spz version v (2 or 3), zlib level 6 (the default)
//   BM_SaveMapSpzFast  .spz version 3, zlib level 1
//   BM_LoadMapSpz      reading the version-3 file back
//
// Counters: bytes (the file size), bytes_per_gaussian, items_per_s. Random
// SH makes .spz compress less than a trained map would (its SH bytes are
// near 128); the positions, scales and colours are smooth as in a map.
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "engine/export/ply.h"
#include "engine/export/splat.h"
#include "engine/export/spz.h"

namespace {

constexpr int kGaussians = 300000;

const dypho::GaussianCloud& BenchCloud() {
  static const dypho::GaussianCloud cloud = [] {
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::normal_distribution<float> g(0.0f, 1.0f);
    dypho::GaussianCloud c;
    c.sh_coeffs = 16;
    std::vector<float> coeffs(48);
    for (int i = 0; i < kGaussians; ++i) {
      const float mean[3] = {3 * u(rng), 1.5f * u(rng), 3 + 2 * u(rng)};
      const float log_scale[3] = {-4.5f + 0.7f * g(rng), -4.5f + 0.7f * g(rng), -4.5f + 0.7f * g(rng)};
      const float quat[4] = {g(rng), g(rng), g(rng), g(rng)};
      for (int j = 0; j < 3; ++j) coeffs[j] = 1.2f * u(rng);
      for (int j = 3; j < 48; ++j) coeffs[j] = 0.1f * g(rng);
      c.Add(mean, log_scale, quat, 2 + 2 * g(rng), coeffs.data());
    }
    return c;
  }();
  return cloud;
}

std::string BenchDir() {
  const auto dir = std::filesystem::temp_directory_path() / "dypho_spz_bench";
  std::filesystem::create_directories(dir);
  return dir.string();
}

void Report(benchmark::State& state, const std::string& path) {
  const double bytes = static_cast<double>(std::filesystem::file_size(path));
  state.counters["bytes"] = bytes;
  state.counters["bytes_per_gaussian"] = bytes / kGaussians;
  state.counters["items_per_s"] =
      benchmark::Counter(static_cast<double>(kGaussians) * state.iterations(), benchmark::Counter::kIsRate);
}

void BM_SaveMapPly(benchmark::State& state) {
  const std::string path = BenchDir() + "/map.ply";
  for (auto _ : state) dypho::SavePly(BenchCloud(), path);
  Report(state, path);
}

void BM_SaveMapSplat(benchmark::State& state) {
  const std::string path = BenchDir() + "/map.splat";
  for (auto _ : state) dypho::SaveSplat(BenchCloud(), path);
  Report(state, path);
}

void BM_SaveMapSpz(benchmark::State& state) {
  const std::string path = BenchDir() + "/map.spz";
  dypho::SpzOptions options;
  options.version = static_cast<int>(state.range(0));
  for (auto _ : state) dypho::SaveSpz(BenchCloud(), path, options);
  Report(state, path);
}

void BM_SaveMapSpzFast(benchmark::State& state) {
  const std::string path = BenchDir() + "/map_fast.spz";
  dypho::SpzOptions options;
  options.compression_level = 1;
  for (auto _ : state) dypho::SaveSpz(BenchCloud(), path, options);
  Report(state, path);
}

void BM_LoadMapSpz(benchmark::State& state) {
  const std::string path = BenchDir() + "/load.spz";
  dypho::SaveSpz(BenchCloud(), path);
  for (auto _ : state) benchmark::DoNotOptimize(dypho::LoadSpz(path).size());
  Report(state, path);
}

BENCHMARK(BM_SaveMapPly)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SaveMapSplat)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SaveMapSpz)->Arg(3)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SaveMapSpzFast)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_LoadMapSpz)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::filesystem::remove_all(std::filesystem::temp_directory_path() / "dypho_spz_bench");
  return 0;
}
