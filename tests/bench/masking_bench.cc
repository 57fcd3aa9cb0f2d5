// Per-stage time of the dynamic masking per 640x480 frame (detector, flow,
// epipolar check, background refinement, shore segmentation, the whole
// pipeline without the detector) on one core (cv::setNumThreads(1)), and the
// mask IoU on a synthetic dynamic sequence (reported as counters).
//
//   build-mask/tests/bench/masking_bench [--benchmark_filter=...]
//
// The sequence: the synthetic room with two walkers (seed 5, 16 frames), the
// sensor depth with Kinect-like noise, a simulated detector (the true mask
// dilated by 5 px, missing walker 0 in frames 3k+1), the map's depth
// rendered at the constant-velocity predicted pose (the exact static scene).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "engine/dataset/dataset.h"
#include "engine/synth/synthetic_scene.h"
#include "masking/background_model.h"
#include "masking/dynamic_masker.h"
#include "masking/epipolar_check.h"
#include "masking/flow_motion.h"
#include "masking/segmenter.h"
#include "masking/shore_segmentation.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

constexpr int kFrames = 16;

struct Sequence {
  std::unique_ptr<SyntheticScene> scene;
  std::vector<SynthFrame> frames;
  std::vector<cv::Mat> gray;
  std::vector<cv::Mat> detections;  // simulated detector
  std::vector<cv::Mat> rendered;    // map depth at the predicted pose
  std::vector<Rigid3d> predicted;   // world_from_cam, constant velocity
  Rigid3d PredictedFromPrev(int i) const { return predicted[i].Inverse() * frames[i - 1].world_from_cam; }
};

// Per-walker masks (nearest body-part box to each pixel's 3-D point).
std::vector<cv::Mat> WalkerMasks(const SyntheticScene& scene, const SynthFrame& f) {
  const std::vector<SynthBox> boxes = scene.walker_boxes(f.index);
  int walkers = 0;
  for (const SynthBox& b : boxes) walkers = std::max(walkers, b.walker + 1);
  std::vector<cv::Mat> masks(walkers);
  for (cv::Mat& m : masks) m = cv::Mat(f.mask.height(), f.mask.width(), CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < f.mask.height(); ++v) {
    for (int u = 0; u < f.mask.width(); ++u) {
      if (!f.mask.at(u, v)) continue;
      const Eigen::Vector3d world =
          f.world_from_cam * scene.camera().Unproject(Eigen::Vector2d(u, v), f.depth.at(u, v));
      double best = 1e9;
      int walker = 0;
      for (const SynthBox& b : boxes) {
        const Eigen::Vector3d q = (b.world_from_box.Inverse() * world).cwiseAbs() - 0.5 * b.size;
        const double d = q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
        if (d < best) best = d, walker = b.walker;
      }
      masks[walker].at<uint8_t>(v, u) = 255;
    }
  }
  return masks;
}

const Sequence& Seq() {
  static const Sequence* seq = [] {
    auto* s = new Sequence;
    SynthOptions o;
    o.frames = kFrames;
    o.seed = 5;
    o.num_walkers = 2;
    s->scene = std::make_unique<SyntheticScene>(o);
    for (int i = 0; i < kFrames; ++i) {
      s->frames.push_back(s->scene->Render(i));
      const SynthFrame& f = s->frames.back();
      cv::Mat gray;
      cv::cvtColor(CvView(f.rgb), gray, cv::COLOR_RGB2GRAY);
      s->gray.push_back(gray);
      cv::Mat det = CvView(f.mask).clone();
      if (i % 3 == 1) {
        const std::vector<cv::Mat> walkers = WalkerMasks(*s->scene, f);
        if (!walkers.empty()) det &= ~walkers[0];
      }
      cv::dilate(det, det, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(11, 11)));
      s->detections.push_back(det);
      const Rigid3d& prev = s->frames[std::max(0, i - 1)].world_from_cam;
      const Rigid3d& prev2 = s->frames[std::max(0, i - 2)].world_from_cam;
      s->predicted.push_back(prev * (prev2.Inverse() * prev));
      s->rendered.push_back(CvView(s->scene->RenderStatic(s->predicted.back(), s->scene->camera()).depth).clone());
    }
    return s;
  }();
  return *seq;
}

class ReplaySegmenter : public Segmenter {
 public:
  Segmentation Segment(const SegmenterInput& input) override {
    return {Seq().detections[std::stoi(input.name)].clone(), {}};
  }
  std::string Name() const override { return "replay"; }
};

// YOLOX-nano on a real TUM frame (or a synthetic one without the shared data).
void BM_Detector_YoloxNano(benchmark::State& state) {
  const std::string model = std::string(DYPHO_SHARED_DATA) + "/models/yolox_nano.onnx";
  if (!std::filesystem::exists(model)) {
    state.SkipWithError("../shared/data/models/yolox_nano.onnx is missing");
    return;
  }
  SegmenterOptions o;
  o.model_path = model;
  const std::unique_ptr<Segmenter> detector = CreateSegmenter(o);
  cv::Mat rgb, depth;
  const std::string frames = std::string(DYPHO_SHARED_DATA) + "/tum_fr3_walking_xyz_3frames";
  if (std::filesystem::exists(frames)) {
    static const Frame frame = OpenDataset(frames)->Load(0);
    rgb = CvView(frame.rgb);
    depth = CvView(frame.depth);
  } else {
    rgb = CvView(Seq().frames[0].rgb);
    depth = CvView(Seq().frames[0].depth_noisy);
  }
  size_t detections = 0;
  for (auto _ : state) detections = detector->Segment({rgb, depth, ""}).detections.size();
  state.counters["detections"] = static_cast<double>(detections);
}
BENCHMARK(BM_Detector_YoloxNano)->Unit(benchmark::kMillisecond)->MinTime(2.0);

void BM_Flow_Dis(benchmark::State& state) {
  const Sequence& s = Seq();
  FlowMotion motion(FlowMotionOptions(), s.scene->camera());
  int i = 1;
  for (auto _ : state) {
    benchmark::DoNotOptimize(motion.ComputeFlow(s.gray[i], s.gray[i - 1]));
    i = i % (kFrames - 1) + 1;
  }
}
BENCHMARK(BM_Flow_Dis)->Unit(benchmark::kMillisecond);

// Pose from the flow, rigid-flow residual, morphology (flow given).
void BM_Flow_MotionMask(benchmark::State& state) {
  const Sequence& s = Seq();
  FlowMotion motion(FlowMotionOptions(), s.scene->camera());
  std::vector<BackwardFlow> flows(kFrames);
  for (int i = 1; i < kFrames; ++i) flows[i] = motion.ComputeFlow(s.gray[i], s.gray[i - 1]);
  int i = 1;
  for (auto _ : state) {
    benchmark::DoNotOptimize(motion.Detect(flows[i], CvView(s.frames[i].depth_noisy), s.PredictedFromPrev(i),
                                           s.detections[i], CvView(s.frames[i - 1].depth_noisy)));
    i = i % (kFrames - 1) + 1;
  }
}
BENCHMARK(BM_Flow_MotionMask)->Unit(benchmark::kMillisecond);

void BM_Flow_CarryMask(benchmark::State& state) {
  const Sequence& s = Seq();
  FlowMotion motion(FlowMotionOptions(), s.scene->camera());
  const BackwardFlow flow = motion.ComputeFlow(s.gray[2], s.gray[1]);
  for (auto _ : state) benchmark::DoNotOptimize(WarpMaskByFlow(s.detections[1], flow));
}
BENCHMARK(BM_Flow_CarryMask)->Unit(benchmark::kMillisecond);

void BM_Epipolar(benchmark::State& state) {
  const Sequence& s = Seq();
  EpipolarChecker checker(EpipolarOptions(), s.scene->camera());
  int i = 1, features = 0;
  for (auto _ : state) {
    features = static_cast<int>(checker.Check(s.gray[i - 1], s.gray[i], {}, s.detections[i]).points.size());
    i = i % (kFrames - 1) + 1;
  }
  state.counters["features"] = features;
}
BENCHMARK(BM_Epipolar)->Unit(benchmark::kMillisecond);

void BM_Background(benchmark::State& state) {
  const Sequence& s = Seq();
  BackgroundModel model(BackgroundOptions(), s.scene->camera());
  int i = 1;
  model.Update({CvView(s.frames[0].depth_noisy), s.detections[0], s.rendered[0], std::nullopt});
  for (auto _ : state) {
    BackgroundInput in{CvView(s.frames[i].depth_noisy), s.detections[i], s.rendered[i], s.PredictedFromPrev(i)};
    benchmark::DoNotOptimize(model.Update(in));
    i = i % (kFrames - 1) + 1;
  }
}
BENCHMARK(BM_Background)->Unit(benchmark::kMillisecond);

void BM_Shore(benchmark::State& state) {
  const cv::Mat rgb = CvView(Seq().frames[3].rgb);
  for (auto _ : state) benchmark::DoNotOptimize(SegmentShore(rgb, ShoreOptions()));
}
BENCHMARK(BM_Shore)->Unit(benchmark::kMillisecond);

// The whole masking without the detector (its masks replayed), with the
// map's rendered depth; IoU of the raw and the final masks over the frames.
void BM_Pipeline_NoDetector(benchmark::State& state) {
  const Sequence& s = Seq();
  const bool with_map = state.range(0) != 0;
  double tp_raw = 0, fp_raw = 0, fn_raw = 0, tp = 0, fp = 0, fn = 0;
  MaskTimings sum;
  long frames = 0;
  for (auto _ : state) {
    state.PauseTiming();
    DynamicMasker masker(MaskingOptions(), s.scene->camera(), std::make_unique<ReplaySegmenter>());
    state.ResumeTiming();
    for (int i = 0; i < kFrames; ++i) {
      MaskerInput in;
      in.rgb = CvView(s.frames[i].rgb);
      in.depth = CvView(s.frames[i].depth_noisy);
      in.name = std::to_string(i);
      if (i > 0) in.cam_from_prev = in.predicted_from_previous = s.PredictedFromPrev(i);
      if (with_map) in.rendered_depth = s.rendered[i];
      const MaskResult r = masker.Process(in);
      if (i < 2) continue;
      state.PauseTiming();
      const cv::Mat truth = CvView(s.frames[i].mask);
      tp_raw += cv::countNonZero(r.raw_mask & truth);
      fp_raw += cv::countNonZero(r.raw_mask & ~truth);
      fn_raw += cv::countNonZero(~r.raw_mask & truth);
      tp += cv::countNonZero(r.mask & truth);
      fp += cv::countNonZero(r.mask & ~truth);
      fn += cv::countNonZero(~r.mask & truth);
      sum.flow_ms += r.timings.flow_ms;
      sum.semantic_ms += r.timings.semantic_ms;
      sum.epipolar_ms += r.timings.epipolar_ms;
      sum.background_ms += r.timings.background_ms;
      sum.total_ms += r.timings.total_ms;
      ++frames;
      state.ResumeTiming();
    }
  }
  state.counters["ms_per_frame"] = sum.total_ms / frames;
  state.counters["flow_ms"] = sum.flow_ms / frames;
  state.counters["epipolar_ms"] = sum.epipolar_ms / frames;
  state.counters["background_ms"] = sum.background_ms / frames;
  state.counters["iou_raw"] = tp_raw / (tp_raw + fp_raw + fn_raw);
  state.counters["iou_final"] = tp / (tp + fp + fn);
  state.counters["precision_final"] = tp / (tp + fp);
  state.counters["recall_final"] = tp / (tp + fn);
}
BENCHMARK(BM_Pipeline_NoDetector)->Arg(1)->Arg(0)->ArgName("map")->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace dypho

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
