#include "masking/dynamic_masker.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/check.h"
#include "masking/coco_classes.h"
#include "masking/mat_checks.h"

namespace dypho {

FeatureFlags FlagFeatures(EpipolarResult epipolar, const cv::Mat& mask) {
  FeatureFlags f;
  f.prev_points = std::move(epipolar.prev_points);
  f.points = std::move(epipolar.points);
  f.valid = std::move(epipolar.valid);
  f.epipolar = std::move(epipolar.dynamic);
  f.has_fundamental = epipolar.has_fundamental;
  f.dynamic.assign(f.points.size(), 0);
  for (size_t i = 0; i < f.points.size(); ++i) {
    if (!f.valid[i]) continue;
    const int u = static_cast<int>(std::lround(f.points[i].x)), v = static_cast<int>(std::lround(f.points[i].y));
    const bool in_mask = u >= 0 && v >= 0 && u < mask.cols && v < mask.rows && mask.at<uint8_t>(v, u);
    f.dynamic[i] = f.epipolar[i] || in_mask;
  }
  return f;
}
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

bool MaskingOptions::IsValid(std::string* error) const {
  std::string sub;
  std::ostringstream msg;
  if (!segmenter.IsValid(&sub))
    msg << "segmenter." << sub;
  else if (!schedule.IsValid(&sub))
    msg << "schedule." << sub;
  else if (!flow.IsValid(&sub))
    msg << "flow." << sub;
  else if (!epipolar.IsValid(&sub))
    msg << "epipolar." << sub;
  else if (!background.IsValid(&sub))
    msg << "background." << sub;
  else if (!shore.IsValid(&sub))
    msg << "shore." << sub;
  else if (!(weight_ramp_px >= 0 && weight_ramp_px <= 1000))
    msg << "weight_ramp_px must be in [0, 1000] (got " << weight_ramp_px << ")";
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

struct DynamicMasker::Impl {
  MaskingOptions options;
  Camera camera;
  cv::Size size;
  std::unique_ptr<AsyncSegmenter> segmenter;
  std::unique_ptr<FlowMotion> flow;
  std::unique_ptr<EpipolarChecker> epipolar;
  std::unique_ptr<BackgroundModel> background;
  cv::Mat prev_gray;
  cv::Mat prev_depth;                 // empty when the previous frame had none
  bool background_continues = false;  // the background belongs to the previous frame
};

DynamicMasker::DynamicMasker(const MaskingOptions& options, const Camera& camera)
    : DynamicMasker(options, camera, nullptr) {}

DynamicMasker::DynamicMasker(const MaskingOptions& options, const Camera& camera, std::unique_ptr<Segmenter> segmenter)
    : impl_(std::make_unique<Impl>()) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "MaskingOptions." << error;
  camera.Validate("DynamicMasker");
  Impl& s = *impl_;
  s.options = options;
  s.camera = camera;
  s.size = cv::Size(camera.width, camera.height);
  if (!segmenter) segmenter = CreateSegmenter(options.segmenter);
  s.segmenter = std::make_unique<AsyncSegmenter>(std::move(segmenter), options.schedule);
  s.flow = std::make_unique<FlowMotion>(options.flow, camera);
  s.epipolar = std::make_unique<EpipolarChecker>(options.epipolar, camera);
  s.background = std::make_unique<BackgroundModel>(options.background, camera);
}

DynamicMasker::~DynamicMasker() = default;

const MaskingOptions& DynamicMasker::options() const { return impl_->options; }
const Camera& DynamicMasker::camera() const { return impl_->camera; }
std::string DynamicMasker::segmenter_name() const { return impl_->segmenter->segmenter().Name(); }
long DynamicMasker::segmenter_waits() const { return impl_->segmenter->waits(); }
double DynamicMasker::segmenter_wait_ms() const { return impl_->segmenter->wait_ms(); }

void DynamicMasker::Reset() {
  impl_->segmenter->Reset();
  impl_->background->Reset();
  impl_->prev_gray.release();
  impl_->prev_depth.release();
  impl_->background_continues = false;
}

MaskResult DynamicMasker::Process(const MaskerInput& in) {
  const Clock::time_point start = Clock::now();
  Impl& s = *impl_;
  const MaskingOptions& o = s.options;
  CheckMat(in.rgb, CV_8UC3, s.size, "rgb");
  CheckOptionalMat(in.depth, CV_32FC1, s.size, "depth");
  CheckOptionalMat(in.rendered_depth, CV_32FC1, s.size, "rendered_depth");
  const bool has_depth = !in.depth.empty();
  MaskResult r;
  cv::Mat gray;
  cv::cvtColor(in.rgb, gray, cv::COLOR_RGB2GRAY);
  const bool has_prev = !s.prev_gray.empty();

  // 1. Backward flow.
  Clock::time_point t = Clock::now();
  const bool carry = o.schedule.interval > 1 || o.schedule.threaded;
  BackwardFlow flow;
  if (has_prev && (carry || (o.use_flow && has_depth))) flow = s.flow->ComputeFlow(gray, s.prev_gray);
  r.timings.flow_ms = MsSince(t);

  // 2. Semantic mask.
  t = Clock::now();
  ScheduledSegmentation semantic = s.segmenter->Next({in.rgb, in.depth, in.name}, flow, in.keyframe, in.ahead);
  r.semantic_mask = semantic.mask;
  r.detections = std::move(semantic.detections);
  r.semantic_source_frame = semantic.source_frame;
  r.timings.semantic_ms = MsSince(t);

  // 3. Flow-motion mask; raw mask.
  t = Clock::now();
  r.flow_mask = cv::Mat(s.size, CV_8UC1, cv::Scalar(0));
  if (o.use_flow && has_depth && !flow.empty()) {
    FlowMotionResult motion = s.flow->Detect(flow, in.depth, in.cam_from_prev, r.semantic_mask, s.prev_depth);
    if (motion.has_pose) {
      r.flow_mask = motion.mask;
      r.flow_computed = true;
      r.cam_from_prev = motion.cam_from_prev;
    }
  }
  if (!r.cam_from_prev) r.cam_from_prev = in.cam_from_prev;
  r.raw_mask = r.semantic_mask | r.flow_mask;
  r.timings.flow_ms += MsSince(t);

  // 4. Epipolar check.
  t = Clock::now();
  EpipolarResult epipolar;
  if (o.use_epipolar && has_prev) epipolar = s.epipolar->Check(s.prev_gray, gray, in.prev_features, r.raw_mask);
  r.timings.epipolar_ms = MsSince(t);

  // 5. Background model and refinement.
  t = Clock::now();
  cv::Mat refined = r.raw_mask;
  if (o.use_background && has_depth) {
    BackgroundInput bg;
    bg.depth = in.depth;
    bg.raw_mask = r.raw_mask;
    bg.rendered_depth = in.rendered_depth;
    if (s.background_continues)
      bg.predicted_from_previous = in.predicted_from_previous ? in.predicted_from_previous : r.cam_from_prev;
    BackgroundOutput out = s.background->Update(bg);
    refined = out.refined_mask;
    r.background_depth = out.background_depth;
    r.background_support = out.support;
    r.added_pixels = out.added_pixels;
    r.removed_pixels = out.removed_pixels;
    s.background_continues = true;
  } else {
    s.background->Reset();
    s.background_continues = false;
  }
  r.timings.background_ms = MsSince(t);

  // 6. Water and sky.
  t = Clock::now();
  if (o.use_shore) {
    r.water_sky_mask = SegmentShore(in.rgb, o.shore).water_sky;
    r.mask = refined | r.water_sky_mask;
  } else {
    r.mask = refined.clone();
  }
  r.timings.shore_ms = MsSince(t);

  // 7. Static weight and feature flags.
  r.static_weight = StaticWeight(r.mask, o.weight_ramp_px);
  r.features = FlagFeatures(std::move(epipolar), r.mask);
  s.prev_gray = gray;
  s.prev_depth = has_depth ? in.depth.clone() : cv::Mat();
  r.timings.total_ms = MsSince(start);
  return r;
}

cv::Mat StaticWeight(const cv::Mat& mask, double ramp_px) {
  CheckMat(mask, CV_8UC1, cv::Size(), "mask");
  cv::Mat weight;
  if (ramp_px <= 0.0 || cv::countNonZero(mask) == 0) {
    mask.convertTo(weight, CV_32F, -1.0 / 255.0, 1.0);
    return weight;
  }
  cv::Mat outside = mask == 0;
  cv::Mat distance;
  cv::distanceTransform(outside, distance, cv::DIST_L2, cv::DIST_MASK_3);
  // distance is 0 on mask pixels and about 1 on their neighbours.
  distance.convertTo(weight, CV_32F, 1.0 / ramp_px);
  cv::min(weight, 1.0, weight);
  return weight;
}

cv::Mat DrawMaskOverlay(const cv::Mat& rgb, const MaskResult& result) {
  CheckMat(rgb, CV_8UC3, cv::Size(), "rgb");
  CheckMat(result.mask, CV_8UC1, rgb.size(), "mask");
  cv::Mat overlay = rgb.clone();
  const cv::Scalar red(255, 40, 40), yellow(255, 220, 0), green(40, 220, 60);
  cv::Mat tinted;
  cv::addWeighted(rgb, 0.5, cv::Mat(rgb.size(), CV_8UC3, red), 0.5, 0.0, tinted);
  tinted.copyTo(overlay, result.mask);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(result.mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  cv::drawContours(overlay, contours, -1, red, 2);
  for (const Detection& d : result.detections) {
    cv::rectangle(overlay, d.box, yellow, 2);
    const std::string name = d.class_id >= 0 && d.class_id < static_cast<int>(CocoClassNames().size())
                                 ? CocoClassNames()[d.class_id]
                                 : std::to_string(d.class_id);
    char label[96];
    std::snprintf(label, sizeof(label), "%s %.2f", name.c_str(), d.score);
    cv::putText(overlay, label, cv::Point(static_cast<int>(d.box.x) + 3, static_cast<int>(d.box.y) + 16),
                cv::FONT_HERSHEY_SIMPLEX, 0.5, yellow, 1, cv::LINE_AA);
  }
  const FeatureFlags& f = result.features;
  for (size_t i = 0; i < f.points.size(); ++i) {
    if (!f.valid[i]) continue;
    cv::circle(overlay, f.points[i], 2, f.dynamic[i] ? red : green, -1, cv::LINE_AA);
  }
  return overlay;
}

}  // namespace dypho
