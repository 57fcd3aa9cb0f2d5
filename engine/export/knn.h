// k nearest neighbours of every point of a fixed 3D point set, by the k-d
// tree of nanoflann (Debian libnanoflann-dev, header only; Blanco and
// Rai 2014, BSD licence). Used by the statistical outlier filter and the
// normals of the point-cloud exports.
//
// Why nanoflann: the exports need exact k-NN on up to a few million points,
// nothing else from a point-cloud library. nanoflann is one header with no
// dependency, exact (eps = 0), and as fast as FLANN's single k-d tree; PCL
// (libpcl-dev: Boost, VTK, FLANN, about 1 GB of packages) and Open3D (not in
// Debian 12) would add a heavy dependency for one search.
#pragma once

#include <vector>

namespace dypho {

struct NeighborLists {
  int k = 0;                  // neighbours per point: min(requested k, N - 1)
  std::vector<int> index;     // [N, k] neighbour indices, nearest first
  std::vector<double> dist2;  // [N, k] squared distances [m^2], ascending
};

// For each of the `n` points of `xyz` ([n, 3]), its `k` nearest other points
// (a point is never its own neighbour; duplicates of it are). Exact (the
// distances are computed in double from the float coordinates),
// multi-threaded (OpenMP) and deterministic: the distances do not depend on
// the thread count. k >= 1; empty lists for n < 2.
NeighborLists NearestOtherPoints(const float* xyz, int n, int k);

// For each of the `n_query` points of `query` ([n_query, 3]), the distance
// [m] to the nearest of the `n_ref` points of `ref` (infinity when n_ref is
// 0). Exact, multi-threaded, deterministic.
std::vector<double> NearestDistances(const float* ref, int n_ref, const float* query, int n_query);

}  // namespace dypho
