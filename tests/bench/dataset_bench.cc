// Reading speed of the TUM reader: frames per second for opening the
// dataset (lists, association, ground truth) and for loading every frame of
// ../shared/data/tum_fr1_rpy_head250 (PNG decode of RGB and 16-bit depth,
// conversion to metres), as one caller thread calling Dataset::Load in turn.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "common/logging.h"
#include "engine/dataset/dataset.h"

namespace {

const std::string kSequence = std::string(DYPHO_SHARED_DATA) + "/tum_fr1_rpy_head250";

bool HaveData(benchmark::State& state) {
  if (std::filesystem::exists(kSequence)) return true;
  state.SkipWithError(("test data missing: " + kSequence).c_str());
  return false;
}

// Opening: parse rgb.txt, depth.txt, associations.txt, groundtruth.txt,
// check that the 500 listed files exist, interpolate ground truth.
void BM_TumOpen(benchmark::State& state) {
  if (!HaveData(state)) return;
  dypho::SetLogLevel(dypho::LogLevel::kWarning);
  for (auto _ : state) {
    auto dataset = dypho::OpenDataset(kSequence);
    benchmark::DoNotOptimize(dataset->size());
  }
}
BENCHMARK(BM_TumOpen)->Unit(benchmark::kMillisecond);

// Loading all 250 frames with decoding; the rate counter is frames per
// wall-clock second. Argument 1: RGB and depth decoded on two threads
// (the default); 0: one thread.
void BM_TumLoadAllFrames(benchmark::State& state) {
  if (!HaveData(state)) return;
  dypho::SetLogLevel(dypho::LogLevel::kWarning);
  dypho::DatasetOptions options;
  options.parallel_decode = state.range(0) != 0;
  const auto dataset = dypho::OpenDataset(kSequence, options);
  size_t frames = 0;
  size_t bytes = 0;
  for (auto _ : state) {
    for (size_t i = 0; i < dataset->size(); ++i) {
      const dypho::Frame frame = dataset->Load(i);
      benchmark::DoNotOptimize(frame.depth.data());
      bytes += frame.rgb.size() + frame.depth.size() * sizeof(float);
      ++frames;
    }
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(frames), benchmark::Counter::kIsRate);
  state.counters["frames"] = static_cast<double>(dataset->size());
  state.SetBytesProcessed(static_cast<int64_t>(bytes));
}
BENCHMARK(BM_TumLoadAllFrames)
    ->ArgName("parallel_decode")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(3.0)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
