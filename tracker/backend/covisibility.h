// Covisibility of keyframes: two keyframes are covisible when they observe
// the same map points; the weight of the pair is the number of points they
// share (ORB-SLAM's covisibility graph, computed on demand from the
// observations of the sparse map instead of being stored).
#pragma once

#include <utility>
#include <vector>

#include "tracker/backend/sparse_map.h"

namespace dypho {

// The keyframes other than `kf` that share at least `min_shared` non-bad
// map points with it, as (keyframe, shared points), most shared first (ties:
// the newer keyframe first). Bad keyframes never appear.
std::vector<std::pair<int, int>> CovisibleKeyframes(const SparseMap& map, int kf, int min_shared);

}  // namespace dypho
