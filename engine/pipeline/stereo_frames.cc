#include "engine/pipeline/stereo_frames.h"

#include "engine/stereo/rig.h"
#include "tracker/cv_view.h"

namespace dypho {

StereoFrames::StereoFrames(const PipelineOptions& options, const Dataset& dataset, OrbTrackerOptions* tracker,
                           EngineOptions* engine)
    : dataset_(dataset) {
  const stereo::StereoRig* rig = dataset.stereo();
  if (rig == nullptr) return;
  sparse_tracking_ = options.sparse_stereo_tracking;
  if (sparse_tracking_) tracker->stereo.baseline = rig->baseline;
  // Without sparse tracking the tracker reads the depth image: it gets the full one.
  if (!sparse_tracking_ || options.stereo_preview_downscale <= 1) return;
  preview_downscale_ = options.stereo_preview_downscale;
  prior_tracking_ = options.stereo_prior_tracking;
  preview_ = std::make_unique<Dataset>(dataset.WithStereoPreview(preview_downscale_));
  engine->stereo_baseline = rig->baseline;
  engine->stereo_method = stereo::DisparityMethodName(rig->disparity.method);
  engine->stereo_max_disparity = rig->disparity.method == stereo::DisparityMethod::kElas
                                     ? rig->disparity.elas.max_disparity
                                     : rig->disparity.sgbm.max_disparity;
}

void StereoFrames::SetTrackerInput(const Frame& frame, TrackerFrame* tf) const {
  if (sparse_tracking_ && !frame.right.empty()) {
    tf->right_image = CvView(frame.right);  // the features' depth from the pair
    if (prior_tracking_ && frame.depth_downscale > 1 && frame.has_depth) tf->stereo_prior_depth = CvView(frame.depth);
  } else if (frame.has_depth) {
    tf->depth = CvView(frame.depth);
  }
}

void StereoFrames::SetEngineInput(const Frame& frame, FrameBuffers* buffers) const {
  if (!frame.has_depth) return;
  buffers->depth_m = frame.depth.data();
  buffers->depth_timestamp = frame.depth_timestamp;
  if (frame.depth_downscale > 1 && !frame.right.empty()) {
    buffers->right_rgb = frame.right.data();
    buffers->keyframe_depth_from_pair = true;
  }
}

}  // namespace dypho
