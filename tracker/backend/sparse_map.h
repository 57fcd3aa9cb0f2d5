// The ORB tracker's sparse map: keyframes (poses and their features) and
// map points, with the observations that tie them. Shared by the tracker
// (tracker/orb_tracker.cc) and the back end (tracker/backend/): covisibility,
// local bundle adjustment and culling. Poses and points only: no Gaussian.
//
// Ids are indices: a map point's id is its index in `points`, a keyframe's
// its index in `keyframes`. Culled entries stay (bad = true) so that ids do
// not move, but a culled keyframe frees its features. A bad point's slot is
// given to a new point once ReleaseBadPoints has released it, so that the
// points vector stays bounded on long runs (a keyframe's slot never is:
// frames stay anchored to culled keyframes).
//
// An observation is (keyframe k, feature f) with keyframes[k].map_points[f]
// == id and (k, f) listed in points[id].keyframes / points[id].features (in
// the same order; the first entry is the keyframe that created the point,
// until that keyframe is culled).
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "common/rigid3.h"
#include "tracker/orb_matcher.h"

namespace dypho {

struct MapPoint {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world [m]
  Descriptor descriptor{};
  double max_distance = 0.0;  // [m] farthest distance at which the point is detectable at level 0
  double min_distance = 0.0;  // [m] nearest distance (at the top level)
  int visible = 1;            // frames in which it was predicted in view
  int found = 1;              // frames in which it was matched as an inlier
  std::vector<int> keyframes; // keyframes observing it (the first one created it)
  std::vector<int> features;  // the feature index in each of those keyframes
  Eigen::Vector3d in_cam = Eigen::Vector3d::Zero();  // [m] where its keyframe saw it (its own camera)
  float row = 0.0f;           // image row of that observation (rolling shutter)
  long visible_stamp = -1;    // last frame counted in `visible`
  long matched_stamp = -1;    // last local-map search in which it was already matched
  long local_stamp = -1;      // last local-map build that took it
  bool bad = false;
  bool released = false;      // bad, and its slot free for a new point (SparseMap::ReleaseBadPoints)
};

struct Keyframe {
  double timestamp = 0.0;
  Rigid3d cam_from_world;           // the camera at the middle image row
  Eigen::Matrix<double, 6, 1> twist = Eigen::Matrix<double, 6, 1>::Zero();  // [1/s] motion (rolling shutter)
  std::vector<cv::Point2f> points;  // undistorted [px]
  std::vector<float> angles;        // [deg]
  std::vector<float> rows;          // image row of each feature in the input image [px] (rolling shutter)
  std::vector<int> levels;          // pyramid level of each feature
  std::vector<float> depths;        // depth reading of each feature [m], 0 = none
  std::vector<float> weights;       // static weight of each feature in [0, 1]
  std::vector<Descriptor> descriptors;
  std::vector<long> map_points;     // per feature, -1 = none
  cv::Mat thumbnail;                // [30, 40] CV_32F, zero mean, unit norm (zero for a flat image)
  bool bad = false;                 // culled as redundant: features freed, no observations

  size_t size() const { return points.size(); }
};

struct SparseMap {
  std::vector<MapPoint> points;
  std::vector<Keyframe> keyframes;
  int live_points = 0;     // points not bad
  int live_keyframes = 0;  // keyframes not bad
  std::vector<long> free_points;  // released slots, taken by NewPoint (last first)

  void Clear() {
    points.clear();
    keyframes.clear();
    free_points.clear();
    live_points = 0;
    live_keyframes = 0;
  }
  // Adds the observation (kf, feature) of point `id`.
  void AddObservation(long id, int kf, int feature);
  // Removes the observation (kf, feature) (which must exist); a point left
  // without observations becomes bad.
  void EraseObservation(int kf, int feature);
  // Marks a point bad and removes all its observations.
  void SetPointBad(long id);
  // Adds `point` in a released slot when there is one, else at the end;
  // returns its id. Does not touch live_points or observations.
  long NewPoint(MapPoint point);
  // Releases the slots of the bad points not yet released: removes the
  // observations they still hold (a point culled by the tracker keeps
  // them), frees their memory and offers their slots to NewPoint. Their ids
  // will name new points: call it only when no copy of an id is held
  // outside this map (a back-end snapshot in flight, the tracker's last
  // frame). Returns the number of slots released.
  int ReleaseBadPoints();
  // Culls a keyframe: removes its observations (points left without any
  // become bad), frees its features, marks it bad.
  void SetKeyframeBad(int kf);
};

}  // namespace dypho
