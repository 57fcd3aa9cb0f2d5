#include "tracker/backend/sparse_map.h"

#include <algorithm>

#include "common/check.h"

namespace dypho {

void SparseMap::AddObservation(long id, int kf, int feature) {
  MapPoint& mp = points[id];
  keyframes[kf].map_points[feature] = id;
  mp.keyframes.push_back(kf);
  mp.features.push_back(feature);
}

void SparseMap::EraseObservation(int kf, int feature) {
  const long id = keyframes[kf].map_points[feature];
  DYPHO_CHECK(id >= 0) << "keyframe " << kf << " feature " << feature << " has no point";
  keyframes[kf].map_points[feature] = -1;
  MapPoint& mp = points[id];
  for (size_t j = 0; j < mp.keyframes.size(); ++j) {
    if (mp.keyframes[j] == kf && mp.features[j] == feature) {
      mp.keyframes.erase(mp.keyframes.begin() + j);
      mp.features.erase(mp.features.begin() + j);
      break;
    }
  }
  if (mp.keyframes.empty() && !mp.bad) {
    mp.bad = true;
    --live_points;
  }
}

void SparseMap::SetPointBad(long id) {
  MapPoint& mp = points[id];
  for (size_t j = 0; j < mp.keyframes.size(); ++j) keyframes[mp.keyframes[j]].map_points[mp.features[j]] = -1;
  mp.keyframes.clear();
  mp.features.clear();
  if (!mp.bad) {
    mp.bad = true;
    --live_points;
  }
}

long SparseMap::NewPoint(MapPoint point) {
  point.bad = false;
  point.released = false;
  if (free_points.empty()) {
    points.push_back(std::move(point));
    return static_cast<long>(points.size()) - 1;
  }
  const long id = free_points.back();
  free_points.pop_back();
  points[id] = std::move(point);
  return id;
}

int SparseMap::ReleaseBadPoints() {
  int released = 0;
  for (long id = 0; id < static_cast<long>(points.size()); ++id) {
    MapPoint& mp = points[id];
    if (!mp.bad || mp.released) continue;
    for (size_t j = 0; j < mp.keyframes.size(); ++j) {
      Keyframe& k = keyframes[mp.keyframes[j]];
      const size_t f = static_cast<size_t>(mp.features[j]);
      if (f < k.map_points.size() && k.map_points[f] == id) k.map_points[f] = -1;
    }
    mp = MapPoint();  // frees its observation lists
    mp.bad = true;
    mp.released = true;
    free_points.push_back(id);
    ++released;
  }
  return released;
}

void SparseMap::SetKeyframeBad(int kf) {
  Keyframe& k = keyframes[kf];
  if (k.bad) return;
  for (size_t f = 0; f < k.map_points.size(); ++f)
    if (k.map_points[f] >= 0) EraseObservation(kf, static_cast<int>(f));
  k.bad = true;
  --live_keyframes;
  // Free the features: a culled keyframe keeps only its pose and timestamp.
  k.points = {};
  k.angles = {};
  k.rows = {};
  k.levels = {};
  k.depths = {};
  k.weights = {};
  k.descriptors = {};
  k.map_points = {};
  k.thumbnail = cv::Mat();
}

}  // namespace dypho
