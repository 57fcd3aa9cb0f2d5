// Dense map, stage 1: the static points of one keyframe, in its camera frame.
//
// A pixel becomes a point when
//   - it is static: outside the keyframe's dynamic mask (which holds the
//     semantic, flow and background-depth masks and, with the shore preset,
//     water and sky: masking/dynamic_masker.h) dilated by mask_margin_px,
//     because mask borders are the least certain pixels;
//   - its depth is valid and finite (0, NaN and infinity are no reading) and
//     in [min_depth, max_depth] (far RGB-D depth is noisy: the error of a
//     structured-light or time-of-flight sensor grows with z^2);
//   - it is confident: not on a depth edge, where the sensor mixes the near
//     and the far surface into "flying pixels" (its depth differs from a
//     4-neighbour's valid depth by more than edge_ratio of its own);
//   - it lies on the grid of `stride` pixels.
// Points are unprojected with the ideal pinhole camera of the undistorted
// keyframe and merged in camera-frame cells of edge `merge_voxel` (centroid,
// mean colour, weight = pixels merged), in the order of their first pixel, so
// a keyframe keeps at most one point per cell of the world map's size.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/camera.h"
#include "engine/map/mapper.h"

namespace dypho {

struct DensePointOptions {
  int stride = 2;             // pixel grid step [px]
  float min_depth = 0.1f;     // [m] nearer readings are dropped
  float max_depth = 4.0f;     // [m] farther readings are dropped
  float edge_ratio = 0.05f;   // depth jump to a 4-neighbour, relative, that marks a depth edge; 0 = keep edges
  int mask_margin_px = 2;     // the dynamic mask is dilated by this many pixels (0 = as is)
  // False, with `error` naming the field and the constraint, for bad values.
  bool IsValid(std::string* error) const;
};

struct KeyframePoints {
  std::vector<float> xyz;       // [N, 3] camera frame [m]
  std::vector<uint8_t> rgb;     // [N, 3]
  std::vector<uint32_t> weight; // [N] pixels merged into the point (>= 1)
  // Pixels of the stride grid, by why they were not used.
  int masked = 0;     // in the (dilated) dynamic mask
  int no_depth = 0;   // 0, NaN or infinite depth
  int out_of_range = 0;  // outside [min_depth, max_depth]
  int edge = 0;       // on a depth edge
  int used = 0;       // merged into points
  int size() const { return static_cast<int>(weight.size()); }
};

// The static points of `keyframe` (see the top of this file). `camera` is
// the keyframe's ideal pinhole camera. Throws InvalidInput naming the field
// for an image of the wrong size or channel count, bad options or
// merge_voxel <= 0. A keyframe without depth, or all masked, gives no point.
KeyframePoints ExtractKeyframePoints(const Camera& camera, const KeyframeInput& keyframe,
                                     const DensePointOptions& options, double merge_voxel);

}  // namespace dypho
