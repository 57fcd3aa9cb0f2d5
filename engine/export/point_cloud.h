// Static dense point cloud from the Gaussian map (DESIGN.md outputs; the
// dense-map step of the nearshore USV SLAM of Zhang et al., J. Mar. Sci. Eng.
// 2025: a coloured cloud of the static scene, cleaned by voxel-grid
// downsampling and statistical outlier removal). The map already holds only
// static content, so every Gaussian mean is a candidate point; its colour is
// the SH base colour clamp(0.5 + C0 f_dc, 0, 1).
//
// The filters are written here and follow PCL's definitions (the neighbour
// search is nanoflann's, engine/export/knn.h):
//   - voxel grid: space is cut into cubes of edge `voxel_size` aligned at the
//     origin (cell = floor(p / voxel_size)); each occupied cell becomes one
//     point at the centroid of its points, coloured with their mean colour.
//     Cells are output in the order of their first point.
//   - statistical outlier removal: d_i = mean distance from point i to its k
//     nearest other points; with mu and sigma the mean and sample standard
//     deviation (n - 1) of all d_i, points with d_i > mu + std_ratio * sigma
//     are removed. Order is kept. Uses nanoflann's k-d tree
//     (engine/export/knn.h); exact, multi-threaded and deterministic.
//
// Output: binary little-endian PLY with `float x y z`, `float nx ny nz` when
// the cloud has normals, and `uchar red green blue` per vertex (read by CloudCompare, MeshLab, Open3D, PCL), in dypho's
// world frame (no axis change). An empty cloud is written as a PLY with 0
// vertices.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "engine/gaussians.h"

namespace dypho {

struct ColoredPoints {
  std::vector<float> xyz;    // [N, 3] world coordinates [m]
  std::vector<uint8_t> rgb;  // [N, 3] 0..255
  std::vector<float> normals;  // [N, 3] unit normals, or empty (none)
  int size() const { return static_cast<int>(xyz.size() / 3); }
  bool has_normals() const { return !normals.empty(); }
};

struct PointCloudOptions {
  // Gaussians whose opacity sigmoid(logit) is below this are skipped [0, 1).
  double min_opacity = 0.0;
  // Edge of the voxel-grid cells [m]; 0 turns downsampling off.
  double voxel_size = 0.0;
  // k of the statistical outlier filter (neighbours per point); 0 turns it off.
  int outlier_neighbors = 0;
  // Points whose mean k-NN distance exceeds mean + outlier_std_ratio * std
  // are removed [standard deviations].
  double outlier_std_ratio = 2.0;

  // False, with `error` naming the field and constraint, for bad values.
  bool IsValid(std::string* error) const;
};

// One point per Gaussian with opacity >= min_opacity (SH base colour).
ColoredPoints PointsFromGaussians(const GaussianCloud& cloud, double min_opacity = 0.0);

// Voxel-grid downsampling (see above). voxel_size > 0.
ColoredPoints VoxelGridDownsample(const ColoredPoints& points, double voxel_size);

// Mean distance from each point to its k nearest other points (k is reduced
// to N - 1 when fewer points exist; all zero for N < 2).
std::vector<double> MeanNeighborDistances(const ColoredPoints& points, int k);

// Statistical outlier removal (see above). k >= 1, std_ratio >= 0.
ColoredPoints RemoveStatisticalOutliers(const ColoredPoints& points, int k, double std_ratio);

// PointsFromGaussians, then the voxel grid, then outlier removal, as enabled
// by `options` (throws InvalidInput for invalid options).
ColoredPoints StaticPointCloud(const GaussianCloud& cloud, const PointCloudOptions& options);

// Writes the coloured PLY atomically (throws InvalidInput on a write error or
// inconsistent arrays).
void SavePointCloudPly(const ColoredPoints& points, const std::string& path);

}  // namespace dypho
