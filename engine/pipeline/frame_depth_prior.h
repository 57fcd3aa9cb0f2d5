// The background model's prior from earlier frames' depth instead of the
// Gaussian map's render (`background_prior` = frames; engine/pipeline/map_depth.h
// is the map's).
//
// The map's render depends on how far the mapping thread has optimised the
// map when the render is made, so with it a threaded run's masks, and then
// its trajectory, depend on timing. This prior depends only on the frames,
// their final masks and their poses: the tracking thread builds it itself,
// in a few milliseconds, and a threaded run gives the sequential run's
// result on any machine.
//
// Store: a tracked frame is kept (its depth at the render camera's size,
// pixels of its final dynamic mask and their neighbours removed) when its
// pose is at least `spacing` from every kept one, with the pose distance
// |c1 - c2| + rotation_weight * angle (camera centres [m], angle [rad]).
// At most `max_frames` are kept; a new one replaces the kept frame farthest
// from it.
// Prior at a pose: the `fuse` kept frames nearest to it, each forward-warped
// to it (WarpMapDepth: z-buffered, one-pixel cracks filled); per pixel the
// depth of the nearest frame that at least `min_agree` of the others confirm
// (a person a mask missed stands elsewhere, or not at all, in the other
// frames, so it does not enter the prior; the static scene agrees).
// A loop closure moves the poses under the kept frames: Clear().
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/rigid3.h"

namespace dypho {

struct FrameDepthPriorOptions {
  int max_frames = 30;           // frames kept, 1..1000
  int fuse = 6;                  // kept frames warped into one prior, 1..max_frames
  int min_agree = 2;             // a depth is used when this many other warped frames agree with it, 0..fuse-1
  double tolerance_abs = 0.03;   // agreement: |z1 - z2| <= abs + rel * z^2: abs [m], > 0
  double tolerance_rel = 0.01;   // ... rel [1/m], >= 0
  double spacing = 0.04;         // a frame is kept this far (pose distance) from every kept one, >= 0
  double rotation_weight = 0.25; // [m/rad] of the pose distance, >= 0
  int mask_margin_px = 4;        // mask pixels removed with this margin (render camera pixels), 0..50

  bool IsValid(std::string* error) const;
};

class FrameDepthPrior {
 public:
  // `camera`: the render camera (the prior's size). Throws InvalidInput
  // naming the field for invalid options.
  FrameDepthPrior(const Camera& camera, const FrameDepthPriorOptions& options);

  // Offers a frame: `depth` CV_32FC1 [m] (0 = none), `mask` CV_8UC1 (255 =
  // dynamic) of the same size (any size with the camera's aspect), its
  // cam_from_world. Returns whether it was kept.
  bool Offer(const cv::Mat& depth, const cv::Mat& mask, const Rigid3d& cam_from_world);
  // The prior at `cam_from_world`: CV_32FC1 of the camera's size, 0 = none;
  // empty when no frame is kept.
  cv::Mat Prior(const Rigid3d& cam_from_world) const;
  void Clear();
  size_t size() const { return kept_.size(); }

  // The pose distance above.
  double Distance(const Rigid3d& a, const Rigid3d& b) const;

 private:
  struct Kept {
    cv::Mat depth;  // render camera size
    Rigid3d cam_from_world;
  };
  Camera camera_;
  FrameDepthPriorOptions options_;
  std::vector<Kept> kept_;
};

}  // namespace dypho
