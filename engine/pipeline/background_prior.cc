#include "engine/pipeline/background_prior.h"

#include <chrono>

#include <opencv2/imgproc.hpp>

#include "engine/pipeline/frame_masks.h"

namespace dypho {
namespace {

kernels::RasterSettings RenderRaster(kernels::RasterSettings raster) {
  // Map renders: one thread of their own (they only need to arrive every
  // few frames), depth only.
  raster.num_threads = 1;
  raster.sh_degree = 0;
  return raster;
}

}  // namespace

BackgroundPrior::BackgroundPrior(const PipelineOptions& options, const Engine* engine, const Camera& camera,
                                 const kernels::RasterSettings& raster)
    : options_(options),
      camera_(camera),
      render_camera_(Scaled(camera, options.render_downscale)),
      map_depth_(engine, render_camera_, RenderRaster(raster), !options.sequential && options.background_prior == "map",
                 options.mapping_nice, options.max_render_age, options.debug_render_delay_ms),
      fixed_render_lag_(!options.sequential && options.max_render_age > 0) {
  if (options.background_prior == "frames") frames_ = std::make_unique<FrameDepthPrior>(render_camera_, options.frame_prior);
}

cv::Mat BackgroundPrior::ForFrame(long k, const Rigid3d& predicted, BackgroundPriorStats* stats) {
  const bool due = last_request_ < 0 || k - last_request_ >= options_.render_every;
  cv::Mat small;
  if (frames_) {
    // Every render_every frames, as the map's renders (the background model
    // carries its background in between).
    if (!due) return cv::Mat();
    const auto t0 = std::chrono::steady_clock::now();
    small = frames_->Prior(predicted);
    if (small.empty()) return cv::Mat();
    last_request_ = k;
    stats->ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  } else {
    // Fixed lag: the answer to the request of frame k - max_render_age
    // first (waiting for it when late), then a new request; a render that
    // has arrived is warped from its pose to this frame's predicted pose.
    std::optional<MapDepth> taken;
    if (fixed_render_lag_) taken = map_depth_.TakeDue(k, &stats->wait_ms);
    if (due && !map_depth_.busy()) {
      map_depth_.Request(predicted, k);
      last_request_ = k;
    }
    if (!fixed_render_lag_) taken = map_depth_.Take();
    if (!taken) return cv::Mat();
    small = taken->depth;
    const Rigid3d target_from_source = predicted * taken->cam_from_world.Inverse();
    if (target_from_source.translation.norm() > 1e-9 ||
        target_from_source.rotation.angularDistance(Eigen::Quaterniond::Identity()) > 1e-9)
      small = WarpMapDepth(small, render_camera_, target_from_source);
    stats->ms += taken->render_ms;
    stats->lag += k - taken->frame;
  }
  ++stats->used;
  cv::Mat full;
  cv::resize(small, full, cv::Size(camera_.width, camera_.height), 0, 0, cv::INTER_NEAREST);
  return full;
}

void BackgroundPrior::Offer(const cv::Mat& depth, const cv::Mat& mask, const Rigid3d& cam_from_world) {
  if (frames_) frames_->Offer(depth, mask, cam_from_world);
}

void BackgroundPrior::PosesMoved() {
  if (frames_) frames_->Clear();
}

}  // namespace dypho
