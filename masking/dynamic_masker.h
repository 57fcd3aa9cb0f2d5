// Dynamic masks per frame: what is static, per pixel and per feature.
//
// Per frame (DynamicMasker::Process), in order:
//  1. Backward optical flow to the previous frame (DIS), when the flow mask
//     is on or the segmenter's masks are carried between its runs.
//  2. Semantic mask from the segmenter (segmenter.h), run on every frame, on
//     every N-th, on keyframes or in its own thread (async_segmenter.h).
//  3. Flow-motion mask (flow_motion.h) from the flow, the current depth and
//     the relative pose (given, refined or estimated from the flow).
//     Raw mask = semantic mask OR flow-motion mask.
//  4. Epipolar motion-consistency check of LK-tracked features
//     (epipolar_check.h); F is fitted outside the raw mask.
//  5. Background depth model and mask refinement (background_model.h) with
//     the map's rendered depth at the predicted pose when the caller has one.
//  6. Water/sky mask (shore_segmentation.h) when enabled, added after the
//     refinement (it is not about motion, so depth must not clear it).
//  7. Static weight image and feature flags.
// Each stage can be switched off; without depth, the flow mask and the
// refinement are skipped and boxes are filled whole.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/rigid3.h"
#include "masking/async_segmenter.h"
#include "masking/background_model.h"
#include "masking/epipolar_check.h"
#include "masking/flow_motion.h"
#include "masking/segmenter.h"
#include "masking/shore_segmentation.h"

namespace dypho {

struct MaskingOptions {
  SegmenterOptions segmenter;         // semantic prior: model or PNG folder, classes, thresholds
  SegmenterScheduleOptions schedule;  // when the segmenter runs (every frame, every N, own thread)
  bool use_flow = true;               // add the flow-motion mask to the raw mask (needs depth)
  FlowMotionOptions flow;             // flow-motion mask
  bool use_epipolar = true;           // flag features that break the epipolar geometry
  EpipolarOptions epipolar;           // epipolar check
  bool use_background = true;         // refine the raw mask with the background depth model (needs depth)
  BackgroundOptions background;       // background depth model and refinement
  bool use_shore = false;             // mask water and sky (boats and docks); off by default
  ShoreOptions shore;                 // shore/water/sky segmentation
  double weight_ramp_px = 8.0;        // static weight rises from 0 at the mask to 1 this far from it [px], >= 0

  // False with `error` naming the field ("flow.scale must be ...").
  bool IsValid(std::string* error) const;
};

struct MaskerInput {
  cv::Mat rgb;       // CV_8UC3, RGB order, the camera's size (required)
  cv::Mat depth;     // CV_32FC1 [m], 0 = invalid; empty = no depth
  std::string name;  // image name without extension (for the png-folder segmenter)
  // Relative pose of this frame's camera to the previous frame's
  // (x_cur = cam_from_prev * x_prev): ground truth or the tracker's
  // prediction; nullopt = estimated from the flow (FlowMotionOptions::estimate_pose).
  std::optional<Rigid3d> cam_from_prev;
  // The map's depth rendered at this frame's predicted pose, CV_32FC1 [m],
  // 0 = nothing rendered; empty = no map.
  cv::Mat rendered_depth;
  // Predicted camera from the previous frame's camera, for warping the
  // previous background; nullopt = the pose the flow stage used (given or
  // estimated), else the previous background is dropped.
  std::optional<Rigid3d> predicted_from_previous;
  // Features of the previous frame to check (e.g. the tracker's keypoints);
  // empty = FAST corners are detected.
  std::vector<cv::Point2f> prev_features;
  bool keyframe = false;  // force a segmenter run on this frame
  // The segmenter input of the frame schedule.look_ahead frames later,
  // loaded on the segmenter's thread (SegmenterScheduleOptions::look_ahead); may be empty.
  AheadLoader ahead;
};

struct MaskTimings {
  double flow_ms = 0.0;        // DIS flow, pose from flow, flow-motion mask [ms]
  double semantic_ms = 0.0;    // segmenter run or mask carrying (incl. waiting for its thread) [ms]
  double epipolar_ms = 0.0;    // LK tracking, F by RANSAC, distances [ms]
  double background_ms = 0.0;  // background fusion and refinement [ms]
  double shore_ms = 0.0;       // water/sky segmentation [ms]
  double total_ms = 0.0;       // the whole Process call [ms]
};

// Features checked on this frame (index i is the same feature in every vector).
struct FeatureFlags {
  std::vector<cv::Point2f> prev_points;  // in the previous frame [px]
  std::vector<cv::Point2f> points;       // tracked into this frame [px]
  std::vector<uint8_t> valid;            // 1 = tracked and passed the border/patch checks
  std::vector<uint8_t> epipolar;         // 1 = farther than the threshold from its epipolar line
  std::vector<uint8_t> dynamic;          // 1 = valid and (epipolar outlier or inside the final mask)
  bool has_fundamental = false;          // false: F could not be fitted (no epipolar flags)
};

// The flags of an epipolar check's features against the final mask (CV_8UC1,
// non-zero = dynamic): a valid feature is dynamic when off its epipolar line
// or inside the mask.
FeatureFlags FlagFeatures(EpipolarResult epipolar, const cv::Mat& mask);

struct MaskResult {
  cv::Mat mask;                          // CV_8UC1, 255 = dynamic: refined mask OR water/sky (the final mask)
  cv::Mat static_weight;                 // CV_32FC1 in [0, 1]: 0 in the mask, 1 at weight_ramp_px and beyond
  cv::Mat raw_mask;                      // CV_8UC1: semantic OR flow-motion
  cv::Mat semantic_mask;                 // CV_8UC1: from the segmenter (run or carried)
  cv::Mat flow_mask;                     // CV_8UC1: flow-motion (all 0 when not computed)
  cv::Mat water_sky_mask;                // CV_8UC1: water and sky (empty when use_shore is off)
  cv::Mat background_depth;              // CV_32FC1 [m]: the background model's B (empty when not used)
  cv::Mat background_support;            // CV_8UC1: its support S (BackgroundOutput::support)
  std::vector<Detection> detections;     // of the segmenter run the semantic mask came from
  long semantic_source_frame = -1;       // frame the semantic mask came from (-1 = none)
  bool flow_computed = false;            // the flow-motion mask was computed (flow, depth and a pose)
  std::optional<Rigid3d> cam_from_prev;  // the pose the flow stage used (given, refined or estimated)
  int added_pixels = 0;                  // refinement: raw-static pixels made dynamic
  int removed_pixels = 0;                // refinement: raw-dynamic pixels made static
  FeatureFlags features;                 // epipolar check (empty on the first frame or when off)
  MaskTimings timings;
};

class DynamicMasker {
 public:
  // Throws InvalidInput naming the field for invalid options or camera, or
  // the file for a missing, unreadable or wrongly shaped model.
  DynamicMasker(const MaskingOptions& options, const Camera& camera);
  // With a segmenter of the caller's (e.g. a host system's own); the
  // options' segmenter fields are then ignored.
  DynamicMasker(const MaskingOptions& options, const Camera& camera, std::unique_ptr<Segmenter> segmenter);
  ~DynamicMasker();
  DynamicMasker(const DynamicMasker&) = delete;
  DynamicMasker& operator=(const DynamicMasker&) = delete;

  // The masks of the next frame of a sequence. Throws InvalidInput naming
  // the argument for an empty rgb, or any image of the wrong type or size.
  // Not thread-safe (one masker per sequence); the returned images are the
  // caller's (not reused by later calls).
  MaskResult Process(const MaskerInput& input);
  // Forgets the previous frame, the background and carried masks.
  void Reset();

  const MaskingOptions& options() const;
  const Camera& camera() const;
  std::string segmenter_name() const;
  // The segmenter's schedule: frames that waited for a late result (fixed
  // lag) and their time waiting [ms], since construction.
  long segmenter_waits() const;
  double segmenter_wait_ms() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Static weight: 0 on mask pixels, rising linearly with the distance from
// the mask to 1 at `ramp_px` (ramp_px = 0: 1 - mask / 255). CV_32FC1.
cv::Mat StaticWeight(const cv::Mat& mask, double ramp_px);

// For inspection: the mask tinted red over the image (alpha 0.5) with its
// outline, detection boxes (yellow) and checked features (green static, red
// dynamic). `rgb` CV_8UC3; the result is RGB.
cv::Mat DrawMaskOverlay(const cv::Mat& rgb, const MaskResult& result);

}  // namespace dypho
