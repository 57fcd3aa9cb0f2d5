// Where movers were lately, in 3D: the flow-motion mask's evidence for the map.
//
// The flow-motion mask (masking/flow_motion.h) finds movers the detector
// misses (a person cut by the image border, blurred, far away), but in fast
// rotation it also marks 10-25 % of a static frame: on the clean TUM fr1/rpy
// frames leaving those pixels out of the keyframes costs the map 0.4 dB of
// novel-view PSNR, while leaving out the flow mask altogether lets a walker
// the detector missed into the map (BENCHMARKS "Which flow-mask pixels the
// map leaves out").
//
// The memory keeps, for the last `frames` frames, the world points of the
// frame's final semantic pixels (the detector's mask after the background
// refinement: people and other movers, not the static ones it cleared),
// sampled on a grid. A flow-only connected component of a later frame is
// confirmed, and kept out of the map, when enough of it lies where those
// points project at the frame's pose (dilated by `radius_px`): a mover seen
// by the detector a moment ago, now beside it or half out of view.
#pragma once

#include <deque>
#include <opencv2/core.hpp>
#include <vector>

#include "common/camera.h"
#include "common/rigid3.h"
#include "masking/dynamic_masker.h"

namespace dypho {

struct MovingMemoryOptions {
  int frames = 30;              // frames a mover's points are kept, >= 1
  int stride_px = 4;            // grid step of the sampled mask pixels [px of the mask], >= 1
  double radius_px = 16.0;      // projected points cover a disc of this radius [px of the mask], >= 0
  double min_overlap = 0.25;    // a flow component is confirmed when this fraction of it is covered, (0, 1]
  int min_component_px = 16;    // smaller flow components are dropped [px], >= 0
  bool remember_confirmed = false;  // confirmed flow components are remembered too (a mover followed by the flow alone)
};

class MovingMemory {
 public:
  // `camera` at the masks' size (the full image for the pipeline's final masks).
  MovingMemory(const MovingMemoryOptions& options, const Camera& camera);

  // Adds a frame: `mover_mask` CV_8UC1 at the camera's size (non-zero = a
  // mover), `depth` CV_32FC1 [m] at the camera's size or 1/n of it (0 =
  // invalid), `cam_from_world` the frame's pose. Frames older than
  // options.frames are forgotten.
  void Add(const cv::Mat& mover_mask, const cv::Mat& depth, const Rigid3d& cam_from_world);

  // The remembered points projected at `cam_from_world`: CV_8UC1 at the
  // camera's size, 255 within radius_px of a projected point in front of
  // the camera.
  cv::Mat Project(const Rigid3d& cam_from_world) const;

  // The components of `flow_only` (CV_8UC1, the camera's size) that the
  // memory confirms at `cam_from_world`; the rest are 0.
  cv::Mat Confirm(const cv::Mat& flow_only, const Rigid3d& cam_from_world) const;

  void Clear() { frames_.clear(); }
  const MovingMemoryOptions& options() const { return options_; }
  size_t points() const;

 private:
  MovingMemoryOptions options_;
  Camera camera_;
  std::deque<std::vector<Eigen::Vector3f>> frames_;
};

// The flow-only pixels of a frame's masks (flow-motion mask outside the
// semantic mask) at the final mask's size (bilinear, then >= 128, as the
// final mask was brought there); all 0 when the flow mask was not computed.
cv::Mat FlowOnlyPixels(const MaskResult& masks);

// The map's mask of a frame (PipelineOptions::map_flow_mask): "all": the
// final mask; "none": without its flow-only pixels; "confirmed": without
// the flow-only components `memory` does not confirm at `cam_from_world`.
// With a memory, the frame's movers (the final mask without its flow-only
// pixels) are then added to it (`depth` CV_32FC1, empty = none added).
cv::Mat MapMask(const MaskResult& masks, const std::string& mode, MovingMemory* memory, const cv::Mat& depth,
                const Rigid3d& cam_from_world);

}  // namespace dypho
