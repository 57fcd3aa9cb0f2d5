// Checks shared by the exporters: a cloud must be consistent and finite
// before it is written in any format.
#pragma once

#include <cmath>
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

}  // namespace dypho::export_internal
