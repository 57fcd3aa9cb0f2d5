// Speed of the synthetic sequence generator (engine/synth).
//
//   BM_WriteSequence/300   the number: a 300-frame 640x480 sequence
//                          written to disk (scene build + render + noise + PNG),
//                          counter frames_per_s
//   BM_BuildScene          textures, trajectory and walker planning
//   BM_RenderFrame         one 640x480 frame (colour, depth, mask, sensor depth)
//   BM_RenderStatic        the static scene at a frame's pose
//
// Output goes to a folder under the system's temporary directory, removed
// afterwards.
#include <filesystem>
#include <string>

#include <benchmark/benchmark.h>

#include "common/logging.h"
#include "engine/synth/synthetic_scene.h"

namespace {

dypho::SynthOptions BenchOptions(int frames) {
  dypho::SynthOptions options;
  options.width = 640;
  options.height = 480;
  options.frames = frames;
  options.num_walkers = 2;
  options.motion = dypho::SynthMotion::kXyz;
  options.seed = 7;
  return options;
}

void BM_WriteSequence(benchmark::State& state) {
  dypho::SetLogLevel(dypho::LogLevel::kWarning);
  const int frames = static_cast<int>(state.range(0));
  const std::string dir = (std::filesystem::temp_directory_path() / "dypho_synth_bench").string();
  for (auto _ : state) {
    std::filesystem::remove_all(dir);
    const dypho::SynthSequenceSummary summary = dypho::WriteSyntheticSequence(BenchOptions(frames), dir);
    benchmark::DoNotOptimize(summary.max_coverage);
  }
  std::filesystem::remove_all(dir);
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(frames) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_WriteSequence)->Arg(300)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

void BM_BuildScene(benchmark::State& state) {
  for (auto _ : state) {
    dypho::SyntheticScene scene(BenchOptions(300));
    benchmark::DoNotOptimize(scene.walk_y_near());
  }
}
BENCHMARK(BM_BuildScene)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_RenderFrame(benchmark::State& state) {
  const dypho::SyntheticScene scene(BenchOptions(300));
  int i = 0;
  for (auto _ : state) {
    dypho::SynthFrame frame = scene.Render(i);
    benchmark::DoNotOptimize(frame.rgb.data());
    i = (i + 37) % scene.num_frames();
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderFrame)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_RenderStatic(benchmark::State& state) {
  const dypho::SyntheticScene scene(BenchOptions(300));
  int i = 0;
  for (auto _ : state) {
    dypho::SynthStaticView view = scene.RenderStatic(scene.trajectory().world_from_cam[i], scene.camera());
    benchmark::DoNotOptimize(view.rgb.data());
    i = (i + 37) % scene.num_frames();
  }
}
BENCHMARK(BM_RenderStatic)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
