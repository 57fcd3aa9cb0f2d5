#include "engine/dense/dense_cloud.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "common/check.h"
#include "engine/export/knn.h"

namespace dypho {

bool DenseCloudOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (min_weight < 1) return fail("min_weight must be >= 1");
  if (outlier_neighbors < 0) return fail("outlier_neighbors must be >= 0");
  if (!(outlier_std_ratio >= 0 && std::isfinite(outlier_std_ratio))) return fail("outlier_std_ratio must be >= 0");
  if (normal_neighbors < 0) return fail("normal_neighbors must be >= 0");
  return true;
}

ColoredPoints DenseCloud(const VoxelMap& map, const DenseCloudOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "dense map: DenseCloudOptions: " << error;
  VoxelPoints vp = map.Points(options.min_weight);
  ColoredPoints& points = vp.points;
  const int n = points.size();
  const int k = std::max(options.outlier_neighbors, options.normal_neighbors);
  if (k == 0 || n < 2) return points;
  const NeighborLists nb = NearestOtherPoints(points.xyz.data(), n, k);
  auto at = [&](int i, int j) { return static_cast<size_t>(i) * nb.k + j; };

  if (options.normal_neighbors > 0) {
    const int kn = std::min(options.normal_neighbors, nb.k);
    points.normals.resize(3 * static_cast<size_t>(n));
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) {
      auto p = [&](int index) {
        return Eigen::Vector3d(points.xyz[3 * index], points.xyz[3 * index + 1], points.xyz[3 * index + 2]);
      };
      Eigen::Vector3d mean = p(i);
      for (int j = 0; j < kn; ++j) mean += p(nb.index[at(i, j)]);
      mean /= kn + 1;
      Eigen::Matrix3d cov = (p(i) - mean) * (p(i) - mean).transpose();
      for (int j = 0; j < kn; ++j) {
        const Eigen::Vector3d d = p(nb.index[at(i, j)]) - mean;
        cov += d * d.transpose();
      }
      Eigen::Vector3d normal(0, 0, 0);
      if (kn >= 2) {
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
        normal = solver.eigenvectors().col(0);  // eigenvalues ascending
      }
      const Eigen::Vector3d view(vp.view[3 * i], vp.view[3 * i + 1], vp.view[3 * i + 2]);
      if (normal.dot(view) < 0) normal = -normal;
      for (int a = 0; a < 3; ++a) points.normals[3 * i + a] = static_cast<float>(normal[a]);
    }
  }
  if (options.outlier_neighbors == 0 || n < 3) return points;
  const int ko = std::min(options.outlier_neighbors, nb.k);
  std::vector<double> d(n, 0.0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < ko; ++j) d[i] += std::sqrt(nb.dist2[at(i, j)]);  // nearest first
    d[i] /= ko;
  }
  double mu = 0;
  for (double v : d) mu += v;
  mu /= n;
  double var = 0;
  for (double v : d) var += (v - mu) * (v - mu);
  const double threshold = mu + options.outlier_std_ratio * std::sqrt(var / (n - 1));
  ColoredPoints out;
  for (int i = 0; i < n; ++i) {
    if (d[i] > threshold) continue;
    out.xyz.insert(out.xyz.end(), &points.xyz[3 * i], &points.xyz[3 * i] + 3);
    out.rgb.insert(out.rgb.end(), &points.rgb[3 * i], &points.rgb[3 * i] + 3);
    if (points.has_normals()) out.normals.insert(out.normals.end(), &points.normals[3 * i], &points.normals[3 * i] + 3);
  }
  return out;
}

}  // namespace dypho
