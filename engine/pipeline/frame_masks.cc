#include "engine/pipeline/frame_masks.h"

#include <chrono>
#include <filesystem>

#include <opencv2/imgproc.hpp>

#include "engine/pipeline/pipeline.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;

// The masks computed at 1/n resolution brought to `size`: the final mask
// (bilinear, then >= 128) and its static weight (bilinear), feature points
// and detection boxes. The intermediate masks stay at 1/n.
void UpscaleMasks(MaskResult* r, int n, const cv::Size& size) {
  r->mask = UpscaledMask(r->mask, size);
  cv::Mat weight;
  cv::resize(r->static_weight, weight, size, 0, 0, cv::INTER_LINEAR);
  weight.setTo(0.0f, r->mask);
  r->static_weight = weight;
  const float s = static_cast<float>(n);
  auto up = [s](cv::Point2f& p) { p = (p + cv::Point2f(0.5f, 0.5f)) * s - cv::Point2f(0.5f, 0.5f); };
  for (cv::Point2f& p : r->features.points) up(p);
  for (cv::Point2f& p : r->features.prev_points) up(p);
  for (Detection& d : r->detections) {
    d.box.x *= s;
    d.box.y *= s;
    d.box.width *= s;
    d.box.height *= s;
    d.mask_roi = cv::Rect();  // the instance masks stay at 1/n (not used past the masker)
    d.mask.release();
  }
}

}  // namespace

cv::Mat UpscaledMask(const cv::Mat& mask, const cv::Size& size) {
  if (mask.size() == size) return mask;
  cv::Mat up;
  cv::resize(mask, up, size, 0, 0, cv::INTER_LINEAR);
  cv::threshold(up, up, 127, 255, cv::THRESH_BINARY);
  return up;
}

Camera Scaled(const Camera& camera, int downscale) {
  Camera c = camera;
  c.distortion = {0, 0, 0, 0, 0};
  if (downscale == 1) return c;
  c.width = camera.width / downscale;
  c.height = camera.height / downscale;
  const double sx = static_cast<double>(c.width) / camera.width, sy = static_cast<double>(c.height) / camera.height;
  c.fx *= sx;
  c.fy *= sy;
  c.cx = (camera.cx + 0.5) * sx - 0.5;
  c.cy = (camera.cy + 0.5) * sy - 0.5;
  return c;
}

Camera Downscaled(const Camera& camera, int n) {
  if (n == 1) return camera;
  Camera c = Scaled(camera, n);
  c.distortion = camera.distortion;
  return c;
}

MaskingOptions ScaleMaskingPixels(MaskingOptions o, int n) {
  if (n == 1) return o;
  const double f = 1.0 / n;
  auto px = [&](int v, int lo) { return v == 0 ? 0 : std::max(lo, static_cast<int>(std::lround(v * f))); };
  auto area = [&](int v) { return static_cast<int>(std::lround(v * f * f)); };
  o.segmenter.dilation_px = px(o.segmenter.dilation_px, 1);
  o.segmenter.box_mask.close_px = px(o.segmenter.box_mask.close_px, 1);
  FlowMotionOptions& fl = o.flow;
  fl.residual_threshold_px *= f;
  fl.open_px = px(fl.open_px, 1);
  fl.close_px = px(fl.close_px, 1);
  fl.min_region_px = area(fl.min_region_px);
  fl.pose_grid_px = std::clamp(px(fl.pose_grid_px, 2), 2, 64);
  fl.pose_inlier_px *= f;
  EpipolarOptions& e = o.epipolar;
  e.grid_cell_px = std::max(8, px(e.grid_cell_px, 8));
  e.lk_window_px = std::clamp(px(e.lk_window_px, 5) | 1, 5, 61);
  e.lk_levels = std::max(0, e.lk_levels - static_cast<int>(std::lround(std::log2(n))));
  e.border_px = px(e.border_px, 1);
  e.ransac_threshold_px *= f;
  e.epipolar_threshold_px *= f;
  BackgroundOptions& b = o.background;
  b.window_radius_px = std::clamp(px(b.window_radius_px, 1), 1, 15);
  b.alignment_px = px(b.alignment_px, 1);
  b.added_open_px = px(b.added_open_px, 1);
  b.min_region_px = area(b.min_region_px);
  o.shore.erode_px = px(o.shore.erode_px, 1);
  o.shore.dilate_px = px(o.shore.dilate_px, 1);
  o.shore.final_erode_px = px(o.shore.final_erode_px, 1);
  o.weight_ramp_px *= f;
  return o;
}

FrameMasker::FrameMasker(const MaskingOptions& masking, const Camera& camera, int downscale, bool bootstrap)
    : masking_(masking),
      camera_(camera),
      md_(downscale),
      bootstrap_(bootstrap),
      mask_camera_(Downscaled(camera, downscale)),
      mask_options_(ScaleMaskingPixels(masking, downscale)) {
  // The epipolar check stays at full resolution: its cost is the RANSAC fit
  // of F, not the image size, and at half resolution its sub-pixel
  // thresholds flag more static features (measured on fr1/rpy: ATE 4.3 cm
  // instead of 1.5 cm, sequential mode).
  if (md_ > 1 && masking.use_epipolar) {
    mask_options_.use_epipolar = false;
    full_res_checker_ = std::make_unique<EpipolarChecker>(masking.epipolar, camera);
  }
  masker_ = std::make_unique<DynamicMasker>(mask_options_, mask_camera_);
}

void FrameMasker::Reset() {
  masker_->Reset();
  prev_gray_.release();
}

cv::Mat FrameMasker::ToMaskSize(const cv::Mat& image, int interpolation) const {
  if (md_ == 1 || image.empty()) return image;
  cv::Mat out;
  cv::resize(image, out, cv::Size(mask_camera_.width, mask_camera_.height), 0, 0, interpolation);
  return out;
}

SegmenterInput FrameMasker::SegmenterInputOf(const Frame& frame) const {
  SegmenterInput s;
  s.rgb = ToMaskSize(CvView(frame.rgb), cv::INTER_AREA);
  if (frame.has_depth) s.depth = ToMaskSize(CvView(frame.depth), cv::INTER_NEAREST);
  s.name = fs::path(frame.rgb_path).stem().string();
  return s;
}

MaskResult FrameMasker::Process(const FrameMaskInput& in) {
  const Frame& frame = *in.frame;
  const int md = md_;
  const MaskingOptions& masking = masking_;
  const Camera& camera = camera_;
  MaskerInput mask_input;
  const cv::Mat full_rgb = CvView(frame.rgb);
  SegmenterInput own = SegmenterInputOf(frame);
  mask_input.rgb = std::move(own.rgb);
  mask_input.depth = std::move(own.depth);
  mask_input.name = std::move(own.name);
  if (in.ahead) {
    // Copied into the loader: it runs on the detector's thread after this call.
    mask_input.ahead = [this, load = in.ahead]() -> std::optional<SegmenterInput> {
      std::optional<Frame> f = load();
      if (!f) return std::nullopt;
      SegmenterInput s = SegmenterInputOf(*f);
      // Own the pixels: the frame goes when this returns.
      s.rgb = s.rgb.clone();
      if (!s.depth.empty()) s.depth = s.depth.clone();
      return s;
    };
  }
  if (in.predicted_from_last) {
    mask_input.cam_from_prev = in.predicted_from_last;
    mask_input.predicted_from_previous = in.predicted_from_last;
  }
  mask_input.rendered_depth = ToMaskSize(in.rendered_depth, cv::INTER_NEAREST);
  // The epipolar check tracks the previous frame's tracker features: at
  // most epipolar.max_features of them, evenly spaced in the list (LK
  // cost grows with the count; the tracker extracts about a thousand).
  const size_t max_checked = static_cast<size_t>(masking.epipolar.max_features);
  if (in.prev_features.size() > max_checked) {
    for (size_t i = 0; i < max_checked; ++i)
      mask_input.prev_features.push_back(in.prev_features[i * in.prev_features.size() / max_checked]);
  } else {
    mask_input.prev_features = in.prev_features;
  }
  const std::vector<cv::Point2f> checked_features = mask_input.prev_features;
  for (cv::Point2f& p : mask_input.prev_features) p = (p + cv::Point2f(0.5f, 0.5f)) * (1.0f / md) - cv::Point2f(0.5f, 0.5f);
  mask_input.keyframe = in.keyframe;
  MaskResult masks = masker_->Process(mask_input);
  // The first frame of a segment has no flow: without help, whatever moves
  // in it would seed the tracker's map. Its flow mask is computed by a
  // scratch masker against the next frame, run backwards (next, then this).
  if (WantsNext(in.segment_start) && frame.has_depth && in.next != nullptr && in.next->has_depth) {
    const Frame& next = *in.next;
    MaskingOptions scratch_options = masking;
    scratch_options.segmenter.kind = "none";
    scratch_options.segmenter.model_path.clear();
    scratch_options.segmenter.png_folder.clear();
    scratch_options.schedule.threaded = false;
    scratch_options.use_epipolar = false;
    scratch_options.use_background = false;
    scratch_options.use_shore = false;
    DynamicMasker scratch(scratch_options, mask_camera_);
    MaskerInput a;
    a.rgb = ToMaskSize(CvView(next.rgb), cv::INTER_AREA);
    a.depth = ToMaskSize(CvView(next.depth), cv::INTER_NEAREST);
    scratch.Process(a);
    MaskerInput b;
    b.rgb = mask_input.rgb;
    b.depth = mask_input.depth;
    const MaskResult back = scratch.Process(b);
    cv::bitwise_or(masks.mask, back.mask, masks.mask);
    masks.static_weight = StaticWeight(masks.mask, mask_options_.weight_ramp_px);
  }
  if (md > 1) UpscaleMasks(&masks, md, cv::Size(camera.width, camera.height));
  if (full_res_checker_) {
    // The masker's epipolar step at full resolution: F fitted outside the
    // raw mask; a feature is dynamic when off its epipolar line or inside
    // the final mask.
    const auto te = std::chrono::steady_clock::now();
    cv::Mat gray;
    cv::cvtColor(full_rgb, gray, cv::COLOR_RGB2GRAY);
    if (!prev_gray_.empty()) {
      cv::Mat raw;
      cv::resize(masks.raw_mask, raw, cv::Size(camera.width, camera.height), 0, 0, cv::INTER_NEAREST);
      masks.features = FlagFeatures(full_res_checker_->Check(prev_gray_, gray, checked_features, raw), masks.mask);
    }
    prev_gray_ = gray;
    masks.timings.epipolar_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - te).count();
  }
  return masks;
}

}  // namespace dypho
