// CPU time of the tracking thread's stages of `dypho run` on real 640x480
// frames (TUM fr1/rpy), one OpenCV thread: the masks (no detector) at full
// and half resolution (masking_downscale), the epipolar check alone, the
// forward warp of a map depth, and a 160x120 map render on one thread.
//
//   build-run/tests/bench/pipeline_bench [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "engine/dataset/dataset.h"
#include "engine/pipeline/map_depth.h"
#include "engine/pipeline/pipeline.h"
#include "masking/dynamic_masker.h"
#include "masking/epipolar_check.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

constexpr int kFrames = 8;

struct Frames {
  Camera camera;
  std::vector<cv::Mat> rgb, depth, gray;
  std::vector<Rigid3d> cam_from_world;  // ground truth
};

const Frames& Data() {
  static const Frames frames = [] {
    Frames f;
    const std::unique_ptr<Dataset> d = OpenDataset(std::string(DYPHO_SHARED_DATA) + "/tum_fr1_rpy_head250");
    f.camera = d->camera();
    for (int i = 0; i < kFrames; ++i) {
      const Frame frame = d->Load(i);
      f.rgb.push_back(CvView(frame.rgb).clone());
      f.depth.push_back(CvView(frame.depth).clone());
      cv::Mat g;
      cv::cvtColor(f.rgb.back(), g, cv::COLOR_RGB2GRAY);
      f.gray.push_back(g);
      f.cam_from_world.push_back(frame.world_from_cam_gt ? frame.world_from_cam_gt->Inverse() : Rigid3d());
    }
    cv::setNumThreads(1);
    return f;
  }();
  return frames;
}

Camera Down(const Camera& c, int n) {
  Camera s = c;
  s.width = c.width / n;
  s.height = c.height / n;
  s.fx /= n;
  s.fy /= n;
  s.cx = (c.cx + 0.5) / n - 0.5;
  s.cy = (c.cy + 0.5) / n - 0.5;
  return s;
}

cv::Mat Resize(const cv::Mat& m, const Camera& c, int interpolation) {
  cv::Mat out;
  cv::resize(m, out, cv::Size(c.width, c.height), 0, 0, interpolation);
  return out;
}

// The masks without a detector (flow, epipolar check, background model
// without a map), at 1/n resolution; arg: n.
void BM_MasksNoDetector(benchmark::State& state) {
  const Frames& f = Data();
  const int n = static_cast<int>(state.range(0));
  MaskingOptions o;
  o.segmenter.kind = "none";
  o = ScaleMaskingPixels(o, n);
  const Camera c = Down(f.camera, n);
  DynamicMasker masker(o, c);
  std::vector<cv::Mat> rgb, depth;
  for (int i = 0; i < kFrames; ++i) {
    rgb.push_back(n == 1 ? f.rgb[i] : Resize(f.rgb[i], c, cv::INTER_AREA));
    depth.push_back(n == 1 ? f.depth[i] : Resize(f.depth[i], c, cv::INTER_NEAREST));
  }
  int i = 0;
  MaskTimings sum;
  int runs = 0;
  for (auto _ : state) {
    MaskerInput in;
    in.rgb = rgb[i];
    in.depth = depth[i];
    if (i > 0) in.cam_from_prev = f.cam_from_world[i] * f.cam_from_world[i - 1].Inverse();
    if (i == 0) masker.Reset();
    const MaskResult r = masker.Process(in);
    if (i > 0) {
      sum.flow_ms += r.timings.flow_ms;
      sum.epipolar_ms += r.timings.epipolar_ms;
      sum.background_ms += r.timings.background_ms;
      ++runs;
    }
    i = (i + 1) % kFrames;
  }
  if (runs > 0) {
    state.counters["flow_ms"] = sum.flow_ms / runs;
    state.counters["epipolar_ms"] = sum.epipolar_ms / runs;
    state.counters["background_ms"] = sum.background_ms / runs;
  }
}
BENCHMARK(BM_MasksNoDetector)->Arg(1)->Arg(2)->ArgName("downscale")->Unit(benchmark::kMillisecond);

// The epipolar check alone on 300 FAST corners at 1/n resolution; args: n,
// RANSAC (0) or MAGSAC (1).
void BM_Epipolar(benchmark::State& state) {
  const Frames& f = Data();
  const int n = static_cast<int>(state.range(0));
  MaskingOptions o = ScaleMaskingPixels(MaskingOptions(), n);
  if (state.range(1) == 1) o.epipolar.method = "magsac";
  const Camera c = Down(f.camera, n);
  EpipolarChecker checker(o.epipolar, c);
  std::vector<cv::Mat> gray;
  for (int i = 0; i < kFrames; ++i) gray.push_back(n == 1 ? f.gray[i] : Resize(f.gray[i], c, cv::INTER_AREA));
  int i = 1;
  double inliers = 0, fitted = 0;
  for (auto _ : state) {
    const EpipolarResult r = checker.Check(gray[i - 1], gray[i]);
    inliers += r.fit_inliers;
    fitted += r.fit_points;
    i = i % (kFrames - 1) + 1;
  }
  state.counters["inlier_fraction"] = fitted > 0 ? inliers / fitted : 0.0;
}
BENCHMARK(BM_Epipolar)
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 1})
    ->Args({2, 1})
    ->ArgNames({"downscale", "magsac"})
    ->Unit(benchmark::kMillisecond);

// Forward warp of a 160x120 map depth to a pose 2 frames later.
void BM_WarpMapDepth(benchmark::State& state) {
  const Frames& f = Data();
  const Camera c = Down(f.camera, 4);
  const cv::Mat depth = Resize(f.depth[0], c, cv::INTER_NEAREST);
  const Rigid3d target_from_source = f.cam_from_world[2] * f.cam_from_world[0].Inverse();
  for (auto _ : state) benchmark::DoNotOptimize(WarpMapDepth(depth, c, target_from_source));
}
BENCHMARK(BM_WarpMapDepth)->Unit(benchmark::kMillisecond);

// A 160x120 depth render of N random Gaussians 1-4 m in front of the
// camera, one thread, SH degree 0; arg: N.
void BM_RenderMapDepth(benchmark::State& state) {
  const Camera c = Down(Data().camera, 4);
  GaussianCloud cloud;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), z(1.0f, 4.0f);
  const float quat[4] = {1, 0, 0, 0}, coeffs[3] = {0.5f, 0.5f, 0.5f};
  for (int64_t k = 0; k < state.range(0); ++k) {
    const float d = z(rng);
    const float mean[3] = {u(rng) * d * 0.6f, u(rng) * d * 0.45f, d};
    const float ls = std::log(0.01f + 0.01f * (u(rng) + 1.0f));
    const float scales[3] = {ls, ls, ls};
    cloud.Add(mean, scales, quat, 1.0f, coeffs);
  }
  kernels::RasterSettings settings;
  settings.num_threads = 1;
  settings.sh_degree = 0;
  for (auto _ : state) benchmark::DoNotOptimize(RenderMapDepth(cloud, c, Rigid3d(), settings));
}
BENCHMARK(BM_RenderMapDepth)->Arg(50000)->Arg(150000)->ArgName("gaussians")->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace dypho

BENCHMARK_MAIN();
