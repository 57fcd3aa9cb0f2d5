#include "engine/export/point_cloud.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <unordered_map>

#include "common/check.h"
#include "common/files.h"
#include "engine/export/cloud_checks.h"
#include "engine/export/knn.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the PLY writer assumes a little-endian host");

namespace dypho {
namespace {

struct CellKey {
  int64_t x, y, z;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
  size_t operator()(const CellKey& k) const {
    // Large odd multipliers (as in Teschner et al. 2003, spatial hashing).
    return static_cast<size_t>(k.x * 73856093LL) ^ static_cast<size_t>(k.y * 19349663LL) ^
           static_cast<size_t>(k.z * 83492791LL);
  }
};

ColoredPoints Select(const ColoredPoints& points, const std::vector<char>& keep) {
  ColoredPoints out;
  for (int i = 0; i < points.size(); ++i) {
    if (!keep[i]) continue;
    out.xyz.insert(out.xyz.end(), &points.xyz[3 * i], &points.xyz[3 * i] + 3);
    out.rgb.insert(out.rgb.end(), &points.rgb[3 * i], &points.rgb[3 * i] + 3);
    if (points.has_normals()) out.normals.insert(out.normals.end(), &points.normals[3 * i], &points.normals[3 * i] + 3);
  }
  return out;
}

}  // namespace

bool PointCloudOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!(min_opacity >= 0.0 && min_opacity < 1.0)) return fail("min_opacity must be in [0, 1)");
  if (!(voxel_size >= 0.0 && std::isfinite(voxel_size))) return fail("voxel_size must be >= 0 and finite [m]");
  if (outlier_neighbors < 0) return fail("outlier_neighbors must be >= 0");
  if (!(outlier_std_ratio >= 0.0 && std::isfinite(outlier_std_ratio))) {
    return fail("outlier_std_ratio must be >= 0 and finite");
  }
  return true;
}

ColoredPoints PointsFromGaussians(const GaussianCloud& cloud, double min_opacity) {
  export_internal::CheckCloudForExport(cloud, "point cloud export");
  ColoredPoints out;
  const int k = cloud.sh_coeffs;
  for (int i = 0; i < cloud.size(); ++i) {
    if (export_internal::Sigmoid(cloud.opacity_logits[i]) < min_opacity) continue;
    out.xyz.insert(out.xyz.end(), &cloud.means[3 * i], &cloud.means[3 * i] + 3);
    for (int c = 0; c < 3; ++c) {
      const double rgb = std::clamp(double(ShDcToRgb(cloud.sh[static_cast<size_t>(i) * k * 3 + c])), 0.0, 1.0);
      out.rgb.push_back(static_cast<uint8_t>(std::lround(rgb * 255)));
    }
  }
  return out;
}

ColoredPoints VoxelGridDownsample(const ColoredPoints& points, double voxel_size) {
  DYPHO_CHECK_INPUT(voxel_size > 0 && std::isfinite(voxel_size)) << "voxel_size must be positive (got " << voxel_size
                                                                 << ")";
  struct Cell {
    double sum[3] = {0, 0, 0};
    double color[3] = {0, 0, 0};
    int count = 0;
  };
  std::vector<Cell> cells;
  std::unordered_map<CellKey, int, CellHash> cell_of;
  cell_of.reserve(points.size());
  const double inv = 1.0 / voxel_size;
  for (int i = 0; i < points.size(); ++i) {
    const float* p = &points.xyz[3 * i];
    const CellKey key{static_cast<int64_t>(std::floor(p[0] * inv)), static_cast<int64_t>(std::floor(p[1] * inv)),
                      static_cast<int64_t>(std::floor(p[2] * inv))};
    auto [it, inserted] = cell_of.emplace(key, static_cast<int>(cells.size()));
    if (inserted) cells.emplace_back();
    Cell& cell = cells[it->second];
    for (int a = 0; a < 3; ++a) {
      cell.sum[a] += p[a];
      cell.color[a] += points.rgb[3 * i + a];
    }
    ++cell.count;
  }
  ColoredPoints out;
  out.xyz.reserve(3 * cells.size());
  out.rgb.reserve(3 * cells.size());
  for (const Cell& cell : cells) {
    for (int a = 0; a < 3; ++a) {
      out.xyz.push_back(static_cast<float>(cell.sum[a] / cell.count));
      out.rgb.push_back(static_cast<uint8_t>(std::lround(cell.color[a] / cell.count)));
    }
  }
  return out;
}

std::vector<double> MeanNeighborDistances(const ColoredPoints& points, int k) {
  DYPHO_CHECK_INPUT(k >= 1) << "outlier filter: k must be >= 1 (got " << k << ")";
  const int n = points.size();
  std::vector<double> mean(n, 0.0);
  const int k_eff = std::min(k, n - 1);
  if (k_eff < 1) return mean;
  const NeighborLists neighbors = NearestOtherPoints(points.xyz.data(), n, k_eff);
  for (int i = 0; i < n; ++i) {
    // Nearest first: the sum does not depend on the search.
    double sum = 0;
    for (int j = 0; j < k_eff; ++j) sum += std::sqrt(neighbors.dist2[static_cast<size_t>(i) * k_eff + j]);
    mean[i] = sum / k_eff;
  }
  return mean;
}

ColoredPoints RemoveStatisticalOutliers(const ColoredPoints& points, int k, double std_ratio) {
  DYPHO_CHECK_INPUT(std_ratio >= 0 && std::isfinite(std_ratio))
      << "outlier filter: std_ratio must be >= 0 (got " << std_ratio << ")";
  const int n = points.size();
  const std::vector<double> d = MeanNeighborDistances(points, k);
  if (n < 3) return points;  // no spread to judge by
  double mu = 0;
  for (double v : d) mu += v;
  mu /= n;
  double var = 0;
  for (double v : d) var += (v - mu) * (v - mu);
  const double sigma = std::sqrt(var / (n - 1));
  const double threshold = mu + std_ratio * sigma;
  std::vector<char> keep(n);
  for (int i = 0; i < n; ++i) keep[i] = d[i] <= threshold;
  return Select(points, keep);
}

ColoredPoints StaticPointCloud(const GaussianCloud& cloud, const PointCloudOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "PointCloudOptions: " << error;
  ColoredPoints points = PointsFromGaussians(cloud, options.min_opacity);
  if (options.voxel_size > 0) points = VoxelGridDownsample(points, options.voxel_size);
  if (options.outlier_neighbors > 0) {
    points = RemoveStatisticalOutliers(points, options.outlier_neighbors, options.outlier_std_ratio);
  }
  return points;
}

void SavePointCloudPly(const ColoredPoints& points, const std::string& path) {
  DYPHO_CHECK_INPUT(points.xyz.size() % 3 == 0 && points.rgb.size() == points.xyz.size())
      << path << ": point cloud has " << points.xyz.size() << " coordinates and " << points.rgb.size()
      << " colour values";
  DYPHO_CHECK_INPUT(!points.has_normals() || points.normals.size() == points.xyz.size())
      << path << ": point cloud has " << points.xyz.size() << " coordinates and " << points.normals.size()
      << " normal values";
  const int n = points.size();
  const bool normals = points.has_normals();
  for (int i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      DYPHO_CHECK_INPUT(std::isfinite(points.xyz[3 * i + a])) << path << ": point " << i << " is not finite";
      DYPHO_CHECK_INPUT(!normals || std::isfinite(points.normals[3 * i + a]))
          << path << ": normal of point " << i << " is not finite";
    }
  }
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\nelement vertex " << n
         << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (normals) header << "property float nx\nproperty float ny\nproperty float nz\n";
  header << "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  const size_t stride = normals ? 27 : 15;
  std::string data = header.str();
  const size_t body = data.size();
  data.resize(body + stride * static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    char* out = &data[body + stride * static_cast<size_t>(i)];
    std::memcpy(out, &points.xyz[3 * i], 12);
    if (normals) std::memcpy(out + 12, &points.normals[3 * i], 12);
    std::memcpy(out + stride - 3, &points.rgb[3 * i], 3);
  }
  WriteTextAtomically(path, data);
}

}  // namespace dypho
