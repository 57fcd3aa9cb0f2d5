#include "tracker/backend/covisibility.h"

#include <algorithm>
#include <unordered_map>

namespace dypho {

std::vector<std::pair<int, int>> CovisibleKeyframes(const SparseMap& map, int kf, int min_shared) {
  std::unordered_map<int, int> shared;
  const Keyframe& k = map.keyframes[kf];
  for (long id : k.map_points) {
    if (id < 0) continue;
    const MapPoint& mp = map.points[id];
    if (mp.bad) continue;
    // A point seen twice by one keyframe (two features) counts once.
    int last = -1;
    std::vector<int> seen = mp.keyframes;
    std::sort(seen.begin(), seen.end());
    for (int other : seen) {
      if (other == kf || other == last) continue;
      last = other;
      ++shared[other];
    }
  }
  std::vector<std::pair<int, int>> out;
  for (const auto& [other, n] : shared)
    if (n >= min_shared && !map.keyframes[other].bad) out.emplace_back(other, n);
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first > b.first;
  });
  return out;
}

}  // namespace dypho
