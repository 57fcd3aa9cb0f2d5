// The integer cell of a point in a voxel grid of cubes aligned at the
// origin (cell = floor(p / edge)), and its hash; shared by the dense map's
// stages.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <tuple>

namespace dypho {

struct VoxelKey {
  int64_t x = 0, y = 0, z = 0;
  bool operator==(const VoxelKey& o) const { return x == o.x && y == o.y && z == o.z; }
  bool operator<(const VoxelKey& o) const { return std::tie(x, y, z) < std::tie(o.x, o.y, o.z); }
};

struct VoxelKeyHash {
  size_t operator()(const VoxelKey& k) const {
    // Large odd multipliers (Teschner et al. 2003, spatial hashing).
    return static_cast<size_t>(k.x * 73856093LL) ^ static_cast<size_t>(k.y * 19349663LL) ^
           static_cast<size_t>(k.z * 83492791LL);
  }
};

inline VoxelKey KeyOf(const double p[3], double inv_edge) {
  return {static_cast<int64_t>(std::floor(p[0] * inv_edge)), static_cast<int64_t>(std::floor(p[1] * inv_edge)),
          static_cast<int64_t>(std::floor(p[2] * inv_edge))};
}

}  // namespace dypho
