#include "tracker/backend/keyframe_culling.h"

#include <algorithm>
#include <sstream>

namespace dypho {

bool KeyframeCullingOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  if (!(redundant_ratio > 0.0 && redundant_ratio <= 1.0)) {
    e << "redundant_ratio must be in (0, 1] (got " << redundant_ratio << ")";
  } else if (min_observers < 1) {
    e << "min_observers must be >= 1 (got " << min_observers << ")";
  } else if (keep_newest < 1) {
    e << "keep_newest must be >= 1 (got " << keep_newest << ")";
  } else {
    return true;
  }
  if (error != nullptr) *error = "KeyframeCullingOptions." + e.str();
  return false;
}

std::vector<int> CullRedundantKeyframes(const std::vector<int>& candidates, const KeyframeCullingOptions& options,
                                        SparseMap* map) {
  std::vector<int> sorted = candidates;
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  const int newest_kept = static_cast<int>(map->keyframes.size()) - options.keep_newest;
  std::vector<int> culled;
  for (int kf : sorted) {
    if (kf == 0 || kf >= newest_kept || map->keyframes[kf].bad) continue;
    const Keyframe& k = map->keyframes[kf];
    int with_depth = 0, redundant = 0;
    for (size_t f = 0; f < k.map_points.size(); ++f) {
      const long id = k.map_points[f];
      if (id < 0 || map->points[id].bad || !(k.depths[f] > 0.0f)) continue;
      ++with_depth;
      const MapPoint& mp = map->points[id];
      int observers = 0;
      for (size_t o = 0; o < mp.keyframes.size() && observers < options.min_observers; ++o) {
        const int other = mp.keyframes[o];
        if (other == kf) continue;
        if (map->keyframes[other].levels[mp.features[o]] <= k.levels[f] + 1) ++observers;
      }
      redundant += observers >= options.min_observers;
    }
    if (with_depth > 0 && redundant >= options.redundant_ratio * with_depth) {
      map->SetKeyframeBad(kf);
      culled.push_back(kf);
    }
  }
  return culled;
}

}  // namespace dypho
