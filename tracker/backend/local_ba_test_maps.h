// Synthetic sparse maps with known answers for the local BA tests
// (local_ba_test.cc, sparse_lm_test.cc): test code, not part of the library.
#pragma once

#include <algorithm>
#include <random>

#include <Eigen/Geometry>

#include "common/camera.h"
#include "common/rigid3.h"
#include "tracker/backend/sparse_map.h"

namespace dypho::ba_test {

inline Camera TestCamera() { return Camera{525.0, 525.0, 319.5, 239.5, 640, 480}; }

// Keyframes along a line looking down +z at a cloud of points; every point
// in view of a keyframe is observed exactly (pixel and depth, level 0,
// weight 1). Returns the true map.
inline SparseMap MakeMap(int num_keyframes, int num_points, double step, unsigned seed) {
  const Camera cam = TestCamera();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-2.0, 2.0 + step * num_keyframes), uy(-1.2, 1.2), uz(2.0, 4.0);
  SparseMap map;
  for (int p = 0; p < num_points; ++p) {
    MapPoint mp;
    mp.position = Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
    map.points.push_back(mp);
  }
  for (int k = 0; k < num_keyframes; ++k) {
    const Rigid3d world_from_cam(Eigen::Quaterniond(Eigen::AngleAxisd(0.02 * k, Eigen::Vector3d::UnitY())),
                                 Eigen::Vector3d(step * k, 0.01 * k, 0.0));
    Keyframe kf;
    kf.timestamp = k;
    kf.cam_from_world = world_from_cam.Inverse();
    map.keyframes.push_back(kf);
    Keyframe& ref = map.keyframes.back();
    for (int p = 0; p < num_points; ++p) {
      const Eigen::Vector3d x = ref.cam_from_world * map.points[p].position;
      if (x.z() < 0.1) continue;
      const double u = cam.fx * x.x() / x.z() + cam.cx, v = cam.fy * x.y() / x.z() + cam.cy;
      if (u < 0 || v < 0 || u > cam.width - 1 || v > cam.height - 1) continue;
      ref.points.emplace_back(static_cast<float>(u), static_cast<float>(v));
      ref.angles.push_back(0.0f);
      ref.rows.push_back(static_cast<float>(v));
      ref.levels.push_back(0);
      ref.depths.push_back(static_cast<float>(x.z()));
      ref.weights.push_back(1.0f);
      ref.descriptors.push_back(Descriptor{});
      ref.map_points.push_back(-1);
      map.AddObservation(p, k, static_cast<int>(ref.points.size()) - 1);
    }
  }
  map.live_points = num_points;
  map.live_keyframes = num_keyframes;
  return map;
}

// The observations are stored in float (pixels rounded by ~3e-5 px, depths
// by ~1e-7 relative): the answers are exact up to that, the tolerances below
// (1e-4 m) leave a wide margin.
inline double MaxPoseError(const SparseMap& a, const SparseMap& b) {
  double e = 0.0;
  for (size_t k = 0; k < a.keyframes.size(); ++k) {
    const Rigid3d d = a.keyframes[k].cam_from_world * b.keyframes[k].cam_from_world.Inverse();
    e = std::max(e, d.translation.norm());
  }
  return e;
}

// Over the points some keyframe sees (the others are in no problem).
inline double MaxPointError(const SparseMap& a, const SparseMap& b) {
  double e = 0.0;
  for (size_t p = 0; p < a.points.size(); ++p)
    if (!b.points[p].keyframes.empty()) e = std::max(e, (a.points[p].position - b.points[p].position).norm());
  return e;
}

// Moves the poses of keyframes first_keyframe.. (2 cm, 0.6 deg per axis) and
// every point (1 cm per axis).
inline void Perturb(SparseMap* map, unsigned seed, size_t first_keyframe) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (size_t k = first_keyframe; k < map->keyframes.size(); ++k) {
    Eigen::Matrix<double, 6, 1> twist;
    for (int i = 0; i < 3; ++i) twist[i] = 0.02 * n(rng);
    for (int i = 3; i < 6; ++i) twist[i] = 0.01 * n(rng);
    map->keyframes[k].cam_from_world = Rigid3d::Exp(twist) * map->keyframes[k].cam_from_world;
  }
  for (MapPoint& mp : map->points) mp.position += 0.01 * Eigen::Vector3d(n(rng), n(rng), n(rng));
}

}  // namespace dypho::ba_test
