// A plain host-side set of Gaussians (no LibTorch): what export, import,
// offline rendering and the demo scene exchange. The mapper keeps its
// optimisable copy as tensors inside engine/torch and converts to this.
#pragma once

#include <string>
#include <vector>

#include "kernels/rasterizer.h"

namespace dypho {

struct GaussianCloud {
  std::vector<float> means;           // [N, 3] world coordinates [m]
  std::vector<float> log_scales;      // [N, 3] log of the standard deviations [log m]
  std::vector<float> quats;           // [N, 4] w, x, y, z
  std::vector<float> opacity_logits;  // [N]
  std::vector<float> sh;              // [N, sh_coeffs, 3]
  int sh_coeffs = 1;                  // 1, 4, 9 or 16

  int size() const { return static_cast<int>(opacity_logits.size()); }
  bool empty() const { return opacity_logits.empty(); }
  // Appends one Gaussian; `coeffs` holds sh_coeffs * 3 values.
  void Add(const float mean[3], const float log_scale[3], const float quat[4], float opacity_logit,
           const float* coeffs);
  // Throws InvalidInput naming the array whose size does not match N.
  void Validate(const std::string& what) const;
  kernels::GaussianParams params() const;
};

// SH degree-0 coefficient for a colour in [0, 1]: (c - 0.5) / C0.
float RgbToShDc(float c);
float ShDcToRgb(float coeff);

}  // namespace dypho
