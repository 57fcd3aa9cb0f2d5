#include "engine/export/knn.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include <nanoflann.hpp>

#include "common/check.h"

namespace dypho {
namespace {

// nanoflann's dataset adaptor over a [n, 3] float array.
struct PointArray {
  const float* xyz;
  size_t n;
  size_t kdtree_get_point_count() const { return n; }
  float kdtree_get_pt(size_t i, size_t dim) const { return xyz[3 * i + dim]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;  // let nanoflann compute the bounding box
  }
};

// Squared Euclidean distance with the differences taken in double (the
// library's L2 adaptors subtract in the float element type, which rounds
// distances to about 1e-8 relative).
struct L2Double {
  using ElementType = float;
  using DistanceType = double;
  const PointArray& data;
  explicit L2Double(const PointArray& d) : data(d) {}
  double evalMetric(const float* a, unsigned b, size_t size) const {
    double sum = 0;
    for (size_t i = 0; i < size; ++i) {
      const double t = double(a[i]) - double(data.kdtree_get_pt(b, i));
      sum += t * t;
    }
    return sum;
  }
  template <typename U, typename V>
  double accum_dist(const U a, const V b, size_t) const {
    const double t = double(a) - double(b);
    return t * t;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<L2Double, PointArray, 3, unsigned>;

}  // namespace

NeighborLists NearestOtherPoints(const float* xyz, int n, int k) {
  DYPHO_CHECK_INPUT(k >= 1) << "nearest neighbours: k must be >= 1 (got " << k << ")";
  DYPHO_CHECK_INPUT(n >= 0) << "nearest neighbours: point count " << n << " is negative";
  NeighborLists out;
  out.k = std::min(k, n - 1);
  if (out.k < 1) {
    out.k = 0;
    return out;
  }
  const PointArray points{xyz, static_cast<size_t>(n)};
  Tree tree(3, points, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  const int kq = out.k + 1;  // the point itself is among the results
  out.index.resize(static_cast<size_t>(n) * out.k);
  out.dist2.resize(static_cast<size_t>(n) * out.k);
#pragma omp parallel
  {
    std::vector<unsigned> index(kq);
    std::vector<double> dist2(kq);
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      const size_t found = tree.knnSearch(&xyz[3 * i], kq, index.data(), dist2.data());
      // Drop the point itself (where several points coincide it may not be
      // first, or not among the results at all: then the farthest goes).
      int j = 0;
      for (size_t r = 0; r < found && j < out.k; ++r) {
        if (static_cast<int>(index[r]) == i) continue;
        out.index[static_cast<size_t>(i) * out.k + j] = static_cast<int>(index[r]);
        out.dist2[static_cast<size_t>(i) * out.k + j] = dist2[r];
        ++j;
      }
      DYPHO_CHECK(j == out.k) << "nearest neighbours: found " << j << " of " << out.k << " for point " << i;
    }
  }
  return out;
}

std::vector<double> NearestDistances(const float* ref, int n_ref, const float* query, int n_query) {
  DYPHO_CHECK_INPUT(n_ref >= 0 && n_query >= 0) << "nearest distances: negative point count";
  std::vector<double> out(n_query, std::numeric_limits<double>::infinity());
  if (n_ref == 0) return out;
  const PointArray points{ref, static_cast<size_t>(n_ref)};
  Tree tree(3, points, nanoflann::KDTreeSingleIndexAdaptorParams(10));
#pragma omp parallel for schedule(static)
  for (int i = 0; i < n_query; ++i) {
    unsigned index = 0;
    double dist2 = 0;
    if (tree.knnSearch(&query[3 * i], 1, &index, &dist2) == 1) out[i] = std::sqrt(dist2);
  }
  return out;
}

}  // namespace dypho
