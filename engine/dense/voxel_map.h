// Dense map, stage 2: the world voxel map of the keyframes' static points.
//
// Space is cut into cubes of edge voxel_size aligned at the world origin; a
// keyframe's points (camera frame, engine/dense/keyframe_points.h) are moved
// by its world_from_cam pose and each lands in one cell, which keeps the
// weighted sums of its positions, colours and viewing directions (unit
// vectors from the point to the camera centre). A cell's point is the
// centroid, its colour the mean colour: a voxel-grid filter with colour
// averaging, built incrementally.
//
// Every keyframe's contribution is kept (its camera-frame points and the pose
// they were added with), so a keyframe can be removed and re-added: when its
// pose changes (refinement, a host's correction, loop closure) its points
// move with it. The sums are integers (positions in units of 1e-5 m, view
// directions of 1e-4), so removing a keyframe subtracts exactly what adding
// it added, and the map does not depend on the order keyframes arrived or
// moved in: the same keyframes and poses give the same map.
//
// Memory is bounded: the map holds at most max_voxels cells; points that
// would open a cell beyond it are left out (counted in stats().dropped_points)
// until a removal makes room and the keyframe is re-added. A keyframe's
// contribution is at most one point per camera-frame cell of the same edge.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/rigid3.h"
#include "engine/dense/keyframe_points.h"
#include "engine/dense/voxel_key.h"
#include "engine/export/point_cloud.h"

namespace dypho {

struct VoxelMapOptions {
  double voxel_size = 0.02;      // cell edge [m]
  int64_t max_voxels = 2000000;  // most cells held (about 100 bytes each)
  bool IsValid(std::string* error) const;  // false with `error` naming the field
};

struct VoxelMapStats {
  int keyframes = 0;
  int64_t voxels = 0;          // occupied cells
  int64_t stored_points = 0;   // camera-frame points kept for all keyframes
  int64_t dropped_points = 0;  // stored points not in the map (max_voxels reached)
  size_t bytes = 0;            // approximate memory of cells and stored points
};

// The map's points with their mean viewing direction (to orient normals).
struct VoxelPoints {
  ColoredPoints points;
  std::vector<float> view;       // [N, 3] mean unit vector to the cameras (not normalised)
  std::vector<uint32_t> weight;  // [N] pixels merged into the point
};

class VoxelMap {
 public:
  explicit VoxelMap(const VoxelMapOptions& options);

  // Adds keyframe `id`'s points at `cam_from_world`. Throws InvalidInput for
  // an id already in the map or a non-finite pose.
  void AddKeyframe(int id, const Rigid3d& cam_from_world, KeyframePoints points);
  // Moves keyframe `id`'s points to a new pose (nothing when the pose is the
  // one they were added with). Throws InvalidInput naming the id when the
  // map has no such keyframe, or for a non-finite pose.
  void SetKeyframePose(int id, const Rigid3d& cam_from_world);
  // Removes keyframe `id`'s points (InvalidInput for an unknown id).
  void RemoveKeyframe(int id);
  bool HasKeyframe(int id) const { return keyframes_.count(id) > 0; }
  // The pose keyframe `id`'s points are at (InvalidInput for an unknown id).
  Rigid3d KeyframePose(int id) const;

  // One point per cell with at least min_weight pixels, ordered by cell
  // (x, then y, then z index): deterministic.
  VoxelPoints Points(uint32_t min_weight = 1) const;
  VoxelMapStats stats() const;
  const VoxelMapOptions& options() const { return options_; }

 private:
  struct Cell {
    int64_t xyz[3] = {0, 0, 0};   // weighted sum of positions [1e-5 m]
    int64_t view[3] = {0, 0, 0};  // weighted sum of unit view directions [1e-4]
    int64_t rgb[3] = {0, 0, 0};   // weighted sum of colours
    int64_t weight = 0;
  };
  struct Contribution {
    Rigid3d cam_from_world;
    KeyframePoints points;
    std::vector<uint8_t> in_map;  // [N] 1 = added to a cell (0: max_voxels reached)
  };
  void Integrate(Contribution* c, int sign);

  VoxelMapOptions options_;
  std::unordered_map<VoxelKey, Cell, VoxelKeyHash> cells_;
  std::map<int, Contribution> keyframes_;
  int64_t dropped_ = 0;
};

}  // namespace dypho
