// How a run feeds a stereo dataset's frames to the tracker and the engine
// (RGB-D datasets pass through unchanged).
//
// The dense disparity of a pair is the costliest step of a stereo frame
// (about 90 ms per KITTI pair on two idle cores), and its full resolution is
// needed only by the maps. With sparse_stereo_tracking the tracker matches
// the pair's features itself, so the frame loader computes only a preview
// depth from the pair at 1/stereo_preview_downscale of the resolution (for
// the per-frame readers of depth: the masks, at masking_downscale, and the
// engine's keyframe choice on its 10 px grid), and the engine computes the
// dense depth of the frames that become keyframes, on its mapping thread
// (FrameBuffers::keyframe_depth_from_pair). Sequential runs map inside
// PushFrame, so they stay deterministic.
#pragma once

#include <memory>

#include "engine/api.h"
#include "engine/dataset/dataset.h"
#include "engine/pipeline/pipeline_options.h"
#include "tracker/orb_tracker.h"

namespace dypho {

class StereoFrames {
 public:
  // Sets the tracker's stereo baseline (sparse tracking) and the engine's
  // stereo fields (preview depths) from the dataset's rig.
  StereoFrames(const PipelineOptions& options, const Dataset& dataset, OrbTrackerOptions* tracker,
               EngineOptions* engine);

  // The dataset to load frames from (the preview-depth copy when previews are on).
  const Dataset& frames() const { return preview_ ? *preview_ : dataset_; }
  bool sparse_tracking() const { return sparse_tracking_; }
  int preview_downscale() const { return preview_downscale_; }

  // The tracker's depth input: the right image (sparse tracking) or the depth image.
  void SetTrackerInput(const Frame& frame, TrackerFrame* tf) const;
  // The engine's depth input: the frame's depth, plus the right image for
  // the keyframes' dense depth when the depth is a preview.
  void SetEngineInput(const Frame& frame, FrameBuffers* buffers) const;

 private:
  const Dataset& dataset_;
  std::unique_ptr<Dataset> preview_;
  bool sparse_tracking_ = false;
  int preview_downscale_ = 1;
  bool prior_tracking_ = false;
};

}  // namespace dypho
