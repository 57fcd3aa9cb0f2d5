// Speed and accuracy of the ORB tracker (tracker/).
//
//   BM_TrackTumRpy            the numbers: every frame of
//                             ../shared/data/tum_fr1_rpy_head250 (decoded into
//                             memory first) tracked on one thread; counters:
//                             median_ms / p95_ms (wall time per Track call),
//                             median_cpu_ms / p95_cpu_ms (thread CPU time, less
//                             sensitive to a busy machine), ate_cm, tracked,
//                             keyframes
//   BM_TrackSyntheticDynamic  a synthetic dynamic sequence (engine/synth, two
//                             walkers, 640x480, 90 frames) with its exact masks
//                             (counters as above, plus ate_no_masks_cm)
//   BM_ExtractOrb             ORB extraction alone on a TUM frame
//   BM_ExtractOrbSynthetic/m  the same on the synthetic frames, m = 1 with the masks
//   BM_OptimizePose/<solver>  motion-only BA on 300 observations (200 with
//                             depth) and 10% outliers: 0 = hand-written
//                             Eigen LM, 1 = Ceres
//
// Run:  build-tracker/tests/bench/tracker_bench --benchmark_counters_tabular=true
// OpenCV runs on one thread (cv::setNumThreads(1)).
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "common/logging.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/ate.h"
#include "engine/eval/trajectory.h"
#include "engine/synth/synthetic_scene.h"
#include "tracker/cv_view.h"
#include "tracker/orb_extractor.h"
#include "tracker/orb_tracker.h"
#include "tracker/pose_optimizer.h"

namespace {

using namespace dypho;

// Kinect v1 RGB rolling-shutter readout used for the TUM sequences.
constexpr double kTumReadout = 0.025;

double ThreadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

struct Sequence {
  Camera camera;
  std::vector<double> timestamps;
  std::vector<cv::Mat> rgb, depth, mask;
  Trajectory ground_truth;
  bool rolling_shutter = false;
};

const Sequence* TumRpy() {
  static std::unique_ptr<Sequence> sequence = [] {
    const std::string folder = std::string(DYPHO_SHARED_DATA) + "/tum_fr1_rpy_head250";
    auto s = std::make_unique<Sequence>();
    try {
      const auto dataset = OpenDataset(folder);
      s->camera = dataset->camera();
      s->ground_truth = dataset->ground_truth();
      s->rolling_shutter = true;
      for (size_t i = 0; i < dataset->size(); ++i) {
        const Frame f = dataset->Load(i);
        s->timestamps.push_back(f.timestamp);
        s->rgb.push_back(CvView(f.rgb).clone());
        s->depth.push_back(f.has_depth ? CvView(f.depth).clone() : cv::Mat());
        s->mask.push_back(cv::Mat());
      }
    } catch (const std::exception& e) {
      std::fprintf(stderr, "tracker_bench: cannot read %s: %s\n", folder.c_str(), e.what());
      s.reset();
    }
    return s;
  }();
  return sequence.get();
}

const Sequence* SyntheticDynamic() {
  static std::unique_ptr<Sequence> sequence = [] {
    SynthOptions options;
    options.frames = 90;
    options.num_walkers = 2;
    options.seed = 3;
    options.motion = SynthMotion::kXyz;
    options.max_coverage = 0.4;
    const SyntheticScene scene(options);
    auto s = std::make_unique<Sequence>();
    s->camera = scene.camera();
    s->ground_truth = scene.trajectory();
    for (int i = 0; i < scene.num_frames(); ++i) {
      const SynthFrame f = scene.Render(i);
      s->timestamps.push_back(f.timestamp);
      s->rgb.push_back(CvView(f.rgb).clone());
      s->depth.push_back(CvView(f.depth_noisy).clone());
      s->mask.push_back(CvView(f.mask).clone());
    }
    return s;
  }();
  return sequence.get();
}

struct RunStats {
  std::vector<double> wall_ms, cpu_ms;
  int tracked = 0, keyframes = 0;
  double ate_m = -1.0;
};

RunStats RunSequence(const Sequence& s, bool use_masks) {
  OrbTrackerOptions options;
  if (s.rolling_shutter) options.rolling_shutter_readout = kTumReadout;
  OrbTracker tracker(s.camera, options);
  RunStats stats;
  Trajectory estimate;
  for (size_t i = 0; i < s.rgb.size(); ++i) {
    TrackerFrame frame;
    frame.timestamp = s.timestamps[i];
    frame.image = s.rgb[i];
    frame.depth = s.depth[i];
    if (use_masks) frame.dynamic_mask = s.mask[i];
    const double cpu0 = ThreadCpuMs();
    const auto t0 = std::chrono::steady_clock::now();
    const TrackResult r = tracker.Track(frame);
    stats.wall_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    stats.cpu_ms.push_back(ThreadCpuMs() - cpu0);
    stats.tracked += IsTracked(r.status);
    stats.keyframes += r.is_keyframe;
    estimate.Add(frame.timestamp, r.cam_from_world.Inverse());
  }
  if (!s.ground_truth.empty()) stats.ate_m = ComputeAte(s.ground_truth, estimate).translation.rmse;
  return stats;
}

void Report(benchmark::State& state, const RunStats& r, size_t frames) {
  state.counters["median_ms"] = Percentile(r.wall_ms, 0.5);
  state.counters["p95_ms"] = Percentile(r.wall_ms, 0.95);
  state.counters["median_cpu_ms"] = Percentile(r.cpu_ms, 0.5);
  state.counters["p95_cpu_ms"] = Percentile(r.cpu_ms, 0.95);
  state.counters["ate_cm"] = 100.0 * r.ate_m;
  state.counters["tracked"] = r.tracked;
  state.counters["frames"] = static_cast<double>(frames);
  state.counters["keyframes"] = r.keyframes;
}

void BM_TrackTumRpy(benchmark::State& state) {
  SetLogLevel(LogLevel::kWarning);
  cv::setNumThreads(1);
  const Sequence* s = TumRpy();
  if (s == nullptr) {
    state.SkipWithError("../shared/data/tum_fr1_rpy_head250 is missing");
    return;
  }
  RunStats last;
  for (auto _ : state) last = RunSequence(*s, false);
  Report(state, last, s->rgb.size());
}
BENCHMARK(BM_TrackTumRpy)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

void BM_TrackSyntheticDynamic(benchmark::State& state) {
  SetLogLevel(LogLevel::kWarning);
  cv::setNumThreads(1);
  const Sequence* s = SyntheticDynamic();
  RunStats last;
  for (auto _ : state) last = RunSequence(*s, true);
  Report(state, last, s->rgb.size());
  state.counters["ate_no_masks_cm"] = 100.0 * RunSequence(*s, false).ate_m;
}
BENCHMARK(BM_TrackSyntheticDynamic)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

void BM_ExtractOrb(benchmark::State& state) {
  cv::setNumThreads(1);
  const Sequence* s = TumRpy();
  if (s == nullptr) {
    state.SkipWithError("../shared/data/tum_fr1_rpy_head250 is missing");
    return;
  }
  OrbExtractor extractor(OrbExtractorOptions(), s->camera);
  cv::Mat gray;
  size_t i = 0;
  for (auto _ : state) {
    cv::cvtColor(s->rgb[i], gray, cv::COLOR_RGB2GRAY);
    const OrbFeatures f = extractor.Extract(gray);
    benchmark::DoNotOptimize(f.descriptors.data);
    i = (i + 17) % s->rgb.size();
  }
}
BENCHMARK(BM_ExtractOrb)->Unit(benchmark::kMillisecond);

void BM_ExtractOrbSynthetic(benchmark::State& state) {
  cv::setNumThreads(1);
  const Sequence* s = SyntheticDynamic();
  OrbExtractor extractor(OrbExtractorOptions(), s->camera);
  cv::Mat gray;
  size_t i = 0;
  const bool masked = state.range(0) != 0;
  for (auto _ : state) {
    cv::cvtColor(s->rgb[i], gray, cv::COLOR_RGB2GRAY);
    const OrbFeatures f = extractor.Extract(gray, masked ? s->mask[i] : cv::Mat());
    benchmark::DoNotOptimize(f.descriptors.data);
    i = (i + 17) % s->rgb.size();
  }
}
BENCHMARK(BM_ExtractOrbSynthetic)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_OptimizePose(benchmark::State& state) {
  Camera camera;
  camera.fx = camera.fy = 525.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  camera.width = 640;
  camera.height = 480;
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.7);
  const Rigid3d truth(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 2, 3).normalized())),
                      Eigen::Vector3d(0.1, -0.2, 0.3));
  std::vector<PoseObservation> obs;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d in_cam(uni(rng) * 1.5, uni(rng) * 1.1, 1.5 + 2.0 * (uni(rng) + 1.0));
    PoseObservation o;
    o.point_world = truth.Inverse() * in_cam;
    o.pixel = camera.Project(in_cam) + Eigen::Vector2d(noise(rng), noise(rng));
    if (i % 10 == 0) o.pixel += Eigen::Vector2d(30.0, -20.0);
    if (i % 3 != 0) o.depth = in_cam.z();
    obs.push_back(o);
  }
  const Rigid3d start = Rigid3d::Exp((Eigen::Matrix<double, 6, 1>() << 0.02, -0.01, 0.03, 0.01, 0.02, -0.015).finished()) * truth;
  PoseOptimizerOptions options;
  options.solver = state.range(0) == 0 ? PoseSolver::kEigenLm : PoseSolver::kCeres;
  double error = 0.0;
  int iterations = 0;
  for (auto _ : state) {
    const PoseOptimizerResult r = OptimizePose(camera, obs, start, options);
    error = (r.cam_from_world.Inverse().translation - truth.Inverse().translation).norm();
    iterations = r.iterations;
    benchmark::DoNotOptimize(error);
  }
  state.counters["position_error_mm"] = 1000.0 * error;
  state.counters["iterations"] = iterations;
}
BENCHMARK(BM_OptimizePose)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
BENCHMARK_MAIN();
