// Checks and small helpers shared by the exporters: a cloud must be
// consistent and finite before it is written in any format.
#pragma once

#include <cmath>
#include <fstream>
#include <string>

#include "common/check.h"
#include "engine/gaussians.h"

namespace dypho::export_internal {

// Throws InvalidInput naming `what` (a file), the first Gaussian and the
// field holding NaN or infinity, or the array whose size is wrong.
inline void CheckCloudForExport(const GaussianCloud& cloud, const std::string& what) {
  cloud.Validate(what);
  const int n = cloud.size();
  const int sh_values = 3 * cloud.sh_coeffs;
  for (int i = 0; i < n; ++i) {
    auto check = [&](const float* v, int count, const char* field) {
      for (int j = 0; j < count; ++j) {
        DYPHO_CHECK_INPUT(std::isfinite(v[j]))
            << what << ": Gaussian " << i << " has a non-finite " << field << " (" << v[j] << ")";
      }
    };
    check(&cloud.means[3 * i], 3, "mean");
    check(&cloud.log_scales[3 * i], 3, "log_scale");
    check(&cloud.quats[4 * i], 4, "quaternion");
    check(&cloud.opacity_logits[i], 1, "opacity_logit");
    check(&cloud.sh[static_cast<size_t>(i) * sh_values], sh_values, "SH coefficient");
  }
}

// Gaussian i's quaternion (w, x, y, z) scaled to unit length. Throws
// InvalidInput naming `what` and the Gaussian when its norm is zero (it
// encodes no rotation; viewers would divide by zero).
inline void NormalizedQuat(const GaussianCloud& cloud, int i, const std::string& what, double q[4]) {
  const float* in = &cloud.quats[4 * i];
  double norm2 = 0;
  for (int j = 0; j < 4; ++j) norm2 += double(in[j]) * in[j];
  DYPHO_CHECK_INPUT(std::isfinite(norm2)) << what << ": Gaussian " << i << " has a non-finite quaternion (" << in[0]
                                          << ", " << in[1] << ", " << in[2] << ", " << in[3] << ")";
  DYPHO_CHECK_INPUT(norm2 > 1e-30) << what << ": Gaussian " << i << " has a zero quaternion";
  const double inv = 1.0 / std::sqrt(norm2);
  for (int j = 0; j < 4; ++j) q[j] = in[j] * inv;
}

// Sign of each SH basis function (3DGS ordering) under (x, y, z) -> (x, -y, -z),
// the rotation by 180 degrees about x between dypho's frame and glTF's / .spz's.
constexpr float kShSignRotX180[16] = {1, -1, -1, 1, -1, 1, 1, -1, 1, -1, 1, -1, -1, 1, -1, 1};

inline double Sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

// The whole file in one read into a buffer of its size (a stringstream copy
// would touch twice the memory). Throws InvalidInput naming the file.
inline std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  DYPHO_CHECK_INPUT(in.good()) << "cannot open " << path;
  const std::streamoff size = in.tellg();
  DYPHO_CHECK_INPUT(size >= 0) << "cannot read " << path;
  std::string data(static_cast<size_t>(size), '\0');
  in.seekg(0);
  in.read(data.data(), size);
  DYPHO_CHECK_INPUT(in.gcount() == size) << "cannot read " << path;
  return data;
}

}  // namespace dypho::export_internal
