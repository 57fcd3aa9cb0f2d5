// Culling of redundant keyframes, so that the map stays bounded on long runs
// over the same place (ORB-SLAM's rule): a keyframe is redundant when at
// least `redundant_ratio` of its map points that have depth are also seen by
// at least `min_observers` other keyframes at the same or a finer scale
// (pyramid level <= its own + 1). The first keyframe and the newest
// `keep_newest` keyframes are never culled.
#pragma once

#include <string>
#include <vector>

#include "tracker/backend/sparse_map.h"

namespace dypho {

struct KeyframeCullingOptions {
  double redundant_ratio = 0.9;  // fraction of points seen elsewhere that makes a keyframe redundant, (0, 1]
  int min_observers = 3;         // other keyframes that must see such a point, >= 1
  int keep_newest = 2;           // newest keyframes never culled, >= 1

  bool IsValid(std::string* error) const;
};

// Culls the redundant keyframes among `candidates` (SparseMap::SetKeyframeBad)
// in ascending id order; returns the ids culled.
std::vector<int> CullRedundantKeyframes(const std::vector<int>& candidates, const KeyframeCullingOptions& options,
                                        SparseMap* map);

}  // namespace dypho
