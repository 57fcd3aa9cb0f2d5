// Dense map, stage 3: the exported cloud. The voxel map's points (cells with
// at least min_weight pixels), cleaned by statistical outlier removal (PCL's
// definition, engine/export/point_cloud.h: mean distance to the k nearest
// points above mean + std_ratio standard deviations) and given normals: the
// eigenvector of the smallest eigenvalue of the covariance of the point and
// its normal_neighbors nearest points (plane fit), turned to face the cameras
// that saw it. The same neighbour search (nanoflann) serves both.
#pragma once

#include <cstdint>
#include <string>

#include "engine/dense/voxel_map.h"
#include "engine/export/point_cloud.h"

namespace dypho {

struct DenseCloudOptions {
  uint32_t min_weight = 1;       // cells merged from fewer pixels are left out
  int outlier_neighbors = 10;    // k of the outlier filter; 0 = no filter
  double outlier_std_ratio = 2.0;  // [standard deviations]
  int normal_neighbors = 10;     // neighbours of the plane fit; 0 = no normals
  bool IsValid(std::string* error) const;  // false with `error` naming the field
};

// The cleaned cloud, in the voxel map's order. Deterministic.
ColoredPoints DenseCloud(const VoxelMap& map, const DenseCloudOptions& options);

}  // namespace dypho
