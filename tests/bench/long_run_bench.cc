// Memory and map size over a long run (issue 17): 3000 frames of the
// synthetic loop (320x240, one 180-frame lap replayed 16.7 times,
// tests/long_loop_run.h) through the ORB tracker with local BA, keyframe and
// map-point culling and loops, sequential (BM_LongLoopRun/0) and threaded
// (BM_LongLoopRun/1: local BA fixed lag 1, loops fixed lag 2, as in dypho
// run). Prints the live keyframes, map points, loops and RSS after every lap;
// counters: the last lap's values, track_ms (mean wall time per Track call),
// local_ba_ms, loop_query_ms, snapshot_ms (threaded: the map copy for the
// loop thread), pose_graph_ms. The second argument picks the local and
// global BA solver (tracker.local_ba.solver): 0 = ceres, 1 = eigen.
//
// Run:  build/tests/bench/long_run_bench --benchmark_counters_tabular=true
//       (one solver: --benchmark_filter='BM_LongLoopRun/[01]/1' for eigen)
#include <benchmark/benchmark.h>

#include "tests/long_loop_run.h"

namespace dypho {
namespace {

void BM_LongLoopRun(benchmark::State& state) {
  const bool threaded = state.range(0) != 0;
  const char* solver = state.range(1) != 0 ? "eigen" : "ceres";
  OrbTrackerOptions o;
  o.local_ba.solver = solver;
  o.local_ba.threaded = threaded;
  o.loops.threaded = threaded;
  if (threaded) {
    o.local_ba.fixed_lag = 1;
    o.loops.fixed_lag = 2;
  }
  testing::LongRun run;
  for (auto _ : state) run = testing::TrackRepeatedLoop(3000, o);
  std::printf("%s, %s:\n", threaded ? "threaded" : "sequential", solver);
  testing::PrintLongRun(run);
  const testing::LongRunSample& last = run.laps.back();
  const OrbBackendStats& b = run.stats;
  auto mean = [](double total, int n) { return n > 0 ? total / n : 0.0; };
  state.counters["live_keyframes"] = last.live_keyframes;
  state.counters["keyframes_made"] = last.keyframes;
  state.counters["live_points"] = last.live_points;
  state.counters["point_slots"] = static_cast<double>(last.point_slots);
  state.counters["loops"] = static_cast<double>(last.loops);
  state.counters["rss_mb"] = last.rss_mb;
  state.counters["tracked"] = run.tracked;
  state.counters["track_ms"] = run.track_ms_total / 3000.0;
  state.counters["local_ba_ms"] = mean(b.local_ba_ms, b.local_ba_runs);
  state.counters["loop_query_ms"] = mean(b.loop_query_ms, b.loop_queries);
  state.counters["snapshot_ms"] = mean(b.loop_snapshot_ms, b.loop_queries);
  state.counters["pose_graph_ms"] = mean(b.pose_graph_ms, static_cast<int>(b.loops.size()));
  state.counters["global_ba_ms"] = mean(b.global_ba_ms, static_cast<int>(b.loops.size()));
}
BENCHMARK(BM_LongLoopRun)->ArgsProduct({{0, 1}, {0, 1}})->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
}  // namespace dypho

BENCHMARK_MAIN();
