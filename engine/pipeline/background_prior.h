// Step 3 of `dypho run`: the background model's prior at a frame's
// predicted pose, from the map's renders (map_depth.h) or from earlier
// frames (frame_depth_prior.h), as PipelineOptions::background_prior says.
#pragma once

#include <memory>
#include <optional>

#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/rigid3.h"
#include "engine/pipeline/frame_depth_prior.h"
#include "engine/pipeline/map_depth.h"
#include "engine/pipeline/pipeline_options.h"

namespace dypho {

class Engine;

// What the priors cost and how old they were (summed; the run divides).
struct BackgroundPriorStats {
  int used = 0;           // priors that reached the background model
  double ms = 0.0;        // their time (map: on the helper thread; frames: on the tracking thread) [ms]
  double lag = 0.0;       // map: their age when used [frames]
  double wait_ms = 0.0;   // map, fixed lag: time the tracking thread waited for a render [ms]
};

class BackgroundPrior {
 public:
  // `camera`: the full-resolution camera; the prior is made at
  // 1/render_downscale of it. `raster`: the mapper's rasterizer settings.
  BackgroundPrior(const PipelineOptions& options, const Engine* engine, const Camera& camera,
                  const kernels::RasterSettings& raster);
  // The prior for frame k at `predicted` (cam_from_world), full resolution
  // (CV_32FC1, 0 = none), or empty when none reaches this frame.
  cv::Mat ForFrame(long k, const Rigid3d& predicted, BackgroundPriorStats* stats);
  // A tracked frame's depth, final mask and pose (frames prior).
  void Offer(const cv::Mat& depth, const cv::Mat& mask, const Rigid3d& cam_from_world);
  // The poses under the kept frames moved (a loop closure, a new map).
  void PosesMoved();

 private:
  const PipelineOptions& options_;
  const Camera camera_, render_camera_;
  MapDepthRenderer map_depth_;
  const bool fixed_render_lag_;
  std::unique_ptr<FrameDepthPrior> frames_;
  long last_request_ = -1;
};

}  // namespace dypho
