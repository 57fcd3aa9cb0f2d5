// The masks of one frame in `dypho run` (step 4 of the pipeline): the
// dynamic masker at 1/masking_downscale resolution, the first frame of a
// segment bootstrapped from the flow to the next frame, the masks brought
// back to full resolution and the epipolar check of the tracker's features
// at full resolution.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/rigid3.h"
#include "engine/dataset/dataset.h"
#include "masking/dynamic_masker.h"
#include "masking/epipolar_check.h"

namespace dypho {

// The pinhole camera of images downscaled by `downscale` (distortion
// dropped): the render camera of the map's depth.
Camera Scaled(const Camera& camera, int downscale);
// The camera of images downscaled by n (distortion kept: its coefficients
// act on normalised coordinates).
Camera Downscaled(const Camera& camera, int n);
// A binary mask (CV_8UC1, 0/255) computed at 1/n brought to `size`:
// bilinear, then >= 128 (the final mask's rule). Returned as is when it
// already has that size.
cv::Mat UpscaledMask(const cv::Mat& mask, const cv::Size& size);

struct FrameMaskInput {
  const Frame* frame = nullptr;            // the frame (full resolution)
  const Frame* next = nullptr;             // segment start: the next frame of the segment (bootstrap), else nullptr
  bool segment_start = false;              // the first frame after a reset
  std::optional<Rigid3d> predicted_from_last;  // predicted cam_from_prev
  cv::Mat rendered_depth;                  // the map's depth at the predicted pose (full resolution, may be empty)
  std::vector<cv::Point2f> prev_features;  // the tracker's features of the previous frame (full resolution)
  bool keyframe = false;                   // the previous frame became a keyframe
  // The frame masking.schedule.look_ahead frames later, read when called
  // (on the detector's thread; nullopt when it cannot be read); may be empty.
  std::function<std::optional<Frame>()> ahead;
};

class FrameMasker {
 public:
  // `masking`: the run's masking options at full resolution; `downscale`:
  // masking_downscale; `bootstrap`: bootstrap_masks.
  FrameMasker(const MaskingOptions& masking, const Camera& camera, int downscale, bool bootstrap);

  // Forgets the previous frames (a new segment).
  void Reset();
  // Wants the next frame for the first frame of a segment (FrameMaskInput::next).
  bool WantsNext(bool segment_start) const { return bootstrap_ && masking_.use_flow && segment_start; }
  // The frame's masks at full resolution.
  MaskResult Process(const FrameMaskInput& input);
  // The masker's options (pixel sizes at the masks' resolution).
  const MaskingOptions& scaled_options() const { return mask_options_; }
  const DynamicMasker& masker() const { return *masker_; }

 private:
  cv::Mat ToMaskSize(const cv::Mat& image, int interpolation) const;
  // What the segmenter gets of `frame` (mask size).
  SegmenterInput SegmenterInputOf(const Frame& frame) const;

  const MaskingOptions masking_;
  const Camera camera_;
  const int md_;
  const bool bootstrap_;
  const Camera mask_camera_;
  MaskingOptions mask_options_;
  std::unique_ptr<DynamicMasker> masker_;
  std::unique_ptr<EpipolarChecker> full_res_checker_;
  cv::Mat prev_gray_;  // full resolution, for full_res_checker_
};

}  // namespace dypho
