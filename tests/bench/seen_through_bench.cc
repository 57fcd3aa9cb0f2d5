// The seen-through keyframe test (engine/dynamic/seen_through.h) on real
// frames with ground-truth poses: time per frame (SeenThroughQueue::Add) and
// per keyframe (the mask against 10 neighbours), and what it marks: on the
// clean tum_fr1_rpy_head250 frames every marked pixel is static (a false
// positive); on a walkers folder with its exact masks, the share of walker
// pixels found. Keyframes at frames 45, 60, 90 and 120 (head250 has a seated
// person who moves from frame ~140 on), for edge_blocks 0-3 (state.range(0))
// with votes 2 and 3 (state.range(1)), without and with the Kinect's
// rolling shutter (readout 25 ms, rates from the ground-truth poses).
//
// Run:  build/tests/bench/seen_through_bench --benchmark_counters_tabular=true
//       [--walkers FOLDER MASKS]   (FOLDER from ../shared/tools/walkers, MASKS its masks/ moved aside)
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "engine/dataset/dataset.h"
#include "engine/dynamic/seen_through.h"
#include "engine/io/image_io.h"
#include "engine/map/sensor_model.h"
#include "engine/map/undistort.h"

namespace dypho {
namespace {

std::string g_walkers, g_masks;

struct Sequence {
  std::unique_ptr<Dataset> dataset;
  std::unique_ptr<Undistorter> undistort;
  std::vector<ImageF> depth;  // undistorted
  std::vector<Rigid3d> cam_from_world;
  std::vector<Eigen::Vector3d> omega;  // from the ground-truth poses of this frame and the one before
  std::vector<double> timestamps;
};

const Sequence& Load(const std::string& folder) {
  static std::map<std::string, Sequence> cache;
  Sequence& s = cache[folder];
  if (s.dataset) return s;
  s.dataset = OpenDataset(folder);
  s.undistort = std::make_unique<Undistorter>(s.dataset->camera());
  for (size_t i = 0; i < s.dataset->size() && i < 151; ++i) {
    const Frame f = s.dataset->Load(i);
    s.depth.push_back(s.undistort->Depth(f.depth));
    s.cam_from_world.push_back(f.world_from_cam_gt->Inverse());
    s.omega.push_back(i == 0 ? Eigen::Vector3d::Zero()
                             : AngularVelocitySince(s.cam_from_world[i - 1], s.timestamps[i - 1],
                                                    s.cam_from_world[i], f.timestamp));
    s.timestamps.push_back(f.timestamp);
  }
  return s;
}

void BM_SeenThrough(benchmark::State& state, bool walkers) {
  const std::string folder = walkers ? g_walkers : std::string(DYPHO_SHARED_DATA) + "/tum_fr1_rpy_head250";
  if (folder.empty()) {
    state.SkipWithError("no --walkers FOLDER MASKS given");
    return;
  }
  const Sequence& s = Load(folder);
  SeenThroughOptions o;
  o.enabled = true;
  o.edge_blocks = static_cast<int>(state.range(0));
  o.votes = static_cast<int>(state.range(1));
  o.readout = state.range(2) ? 0.025 : 0.0;  // the Kinect v1 readout dypho run uses for TUM
  long long marked = 0, pixels = 0, walker = 0, found = 0;
  double add_ms = 0, mask_ms = 0;
  int adds = 0, masks = 0;
  using Clock = std::chrono::steady_clock;
  for (auto _ : state) {
    for (int k : {45, 60, 90, 120}) {
      SeenThroughQueue q(s.undistort->pinhole(), o);
      long long key = -1;
      for (int i = k - o.window; i <= k + o.window; ++i) {
        const auto t0 = Clock::now();
        const long long index = q.Add(s.depth[static_cast<size_t>(i)], s.cam_from_world[static_cast<size_t>(i)],
                                     s.omega[static_cast<size_t>(i)]);
        add_ms += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        ++adds;
        if (i == k) key = index;
      }
      KeyframeInput in;
      in.depth = s.depth[static_cast<size_t>(k)];
      in.cam_from_world = s.cam_from_world[static_cast<size_t>(k)];
      in.angular_velocity = s.omega[static_cast<size_t>(k)];
      q.Hold(0, std::move(in), key);
      const auto t0 = Clock::now();
      const auto out = q.Release(true);
      mask_ms += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      ++masks;
      const ImageU8& m = out[0].second.dynamic_mask;
      ImageU8 exact;
      if (walkers) {
        char name[64];
        std::snprintf(name, sizeof name, "/%.6f.png", s.timestamps[static_cast<size_t>(k)]);
        exact = s.undistort->Mask(ReadGray8(g_masks + name));
      }
      for (int y = 0; y < m.height(); ++y)
        for (int x = 0; x < m.width(); ++x) {
          const bool w = !exact.empty() && exact.at(x, y) != 0;
          ++pixels;
          walker += w;
          if (m.at(x, y) != 0) (w ? found : marked) += 1;
        }
    }
  }
  state.counters["static_marked_pct"] = 100.0 * marked / pixels;
  if (walkers) state.counters["walker_found_pct"] = walker ? 100.0 * found / walker : 0.0;
  state.counters["add_ms"] = add_ms / adds;
  state.counters["mask_ms"] = mask_ms / masks;
}

void Args(benchmark::internal::Benchmark* b) {
  for (int rolling : {0, 1})
    for (int votes : {2, 3})
      for (int edge = 0; edge <= 3; ++edge) b->Args({edge, votes, rolling});
  b->ArgNames({"edge_blocks", "votes", "rolling_shutter"})->Iterations(1)->Unit(benchmark::kMillisecond);
}

BENCHMARK_CAPTURE(BM_SeenThrough, clean_head250, false)->Apply(Args);
BENCHMARK_CAPTURE(BM_SeenThrough, walkers, true)->Apply(Args);

}  // namespace
}  // namespace dypho

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strcmp(argv[i], "--walkers") == 0 && i + 2 < argc) {
      dypho::g_walkers = argv[i + 1];
      dypho::g_masks = argv[i + 2];
      i += 2;
    } else {
      rest.push_back(argv[i]);
    }
  }
  int n = static_cast<int>(rest.size());
  benchmark::Initialize(&n, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
