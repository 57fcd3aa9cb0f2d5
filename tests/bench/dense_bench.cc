// The dense map's cost on real frames (tum_fr1_rpy_head250, every 10th frame
// a keyframe, ground-truth poses): per keyframe, pixel selection
// (ExtractKeyframePoints), integration into the voxel map, both, and the
// export (outlier removal and normals). Figures in BENCHMARKS.md.
//   build/tests/bench/dense_bench
#include <benchmark/benchmark.h>

#include <cstdio>

#include "engine/dataset/dataset.h"
#include "engine/dense/dense_mapper.h"
#include "engine/map/undistort.h"

namespace dypho {
namespace {

struct Keyframes {
  Camera camera;
  std::vector<KeyframeInput> frames;
};

const Keyframes& Load() {
  static const Keyframes k = [] {
    Keyframes out;
    const auto dataset = OpenDataset(std::string(DYPHO_SHARED_DATA) + "/tum_fr1_rpy_head250");
    const Undistorter undistort(dataset->camera());
    out.camera = undistort.pinhole();
    for (size_t i = 0; i < dataset->size(); i += 10) {
      const Frame f = dataset->Load(i);
      if (!f.has_depth || !f.world_from_cam_gt) continue;
      KeyframeInput in;
      in.rgb = undistort.Rgb(f.rgb);
      in.depth = undistort.Depth(f.depth);
      in.dynamic_mask = undistort.ExcludedPixels(ImageU8());
      in.cam_from_world = f.world_from_cam_gt->Inverse();
      out.frames.push_back(std::move(in));
    }
    return out;
  }();
  return k;
}

void BM_DenseExtract(benchmark::State& state) {
  const Keyframes& k = Load();
  const DenseMapOptions o;
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(ExtractKeyframePoints(k.camera, k.frames[i++ % k.frames.size()], o.points, o.map.voxel_size));
  }
}
BENCHMARK(BM_DenseExtract)->Unit(benchmark::kMillisecond);

// All keyframes into a fresh map; time per keyframe.
void BM_DenseIntegrate(benchmark::State& state) {
  const Keyframes& k = Load();
  const DenseMapOptions o;
  std::vector<KeyframePoints> points;
  for (const KeyframeInput& f : k.frames) points.push_back(ExtractKeyframePoints(k.camera, f, o.points, o.map.voxel_size));
  for (auto _ : state) {
    VoxelMap map(o.map);
    for (size_t i = 0; i < points.size(); ++i) map.AddKeyframe(static_cast<int>(i), k.frames[i].cam_from_world, points[i]);
    benchmark::DoNotOptimize(map.stats());
  }
  state.counters["keyframes"] = static_cast<double>(points.size());
}
BENCHMARK(BM_DenseIntegrate)->Unit(benchmark::kMillisecond);

// The dense thread's work for one keyframe (extraction and integration),
// and a pose update (remove and re-add), on the map of all keyframes.
void BM_DenseKeyframeAndPoseUpdate(benchmark::State& state) {
  const Keyframes& k = Load();
  const DenseMapOptions o;
  VoxelMap map(o.map);
  for (size_t i = 1; i < k.frames.size(); ++i)
    map.AddKeyframe(static_cast<int>(i), k.frames[i].cam_from_world,
                    ExtractKeyframePoints(k.camera, k.frames[i], o.points, o.map.voxel_size));
  const bool update = state.range(0) == 1;
  if (update) map.AddKeyframe(0, k.frames[0].cam_from_world, ExtractKeyframePoints(k.camera, k.frames[0], o.points, o.map.voxel_size));
  Rigid3d moved = k.frames[0].cam_from_world;
  for (auto _ : state) {
    if (update) {
      moved.translation.x() += 1e-3;
      map.SetKeyframePose(0, moved);
    } else {
      map.AddKeyframe(0, k.frames[0].cam_from_world,
                      ExtractKeyframePoints(k.camera, k.frames[0], o.points, o.map.voxel_size));
      state.PauseTiming();
      map.RemoveKeyframe(0);
      state.ResumeTiming();
    }
  }
  state.SetLabel(update ? "pose update" : "new keyframe");
}
BENCHMARK(BM_DenseKeyframeAndPoseUpdate)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_DenseExport(benchmark::State& state) {
  const Keyframes& k = Load();
  const DenseMapOptions o;
  VoxelMap map(o.map);
  for (size_t i = 0; i < k.frames.size(); ++i)
    map.AddKeyframe(static_cast<int>(i), k.frames[i].cam_from_world,
                    ExtractKeyframePoints(k.camera, k.frames[i], o.points, o.map.voxel_size));
  int n = 0;
  for (auto _ : state) n = DenseCloud(map, o.cloud).size();
  state.counters["points"] = n;
  state.counters["voxels"] = static_cast<double>(map.stats().voxels);
  state.counters["MB"] = map.stats().bytes / 1e6;
}
BENCHMARK(BM_DenseExport)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace dypho

BENCHMARK_MAIN();
