#include "engine/gaussians.h"

#include "common/check.h"

namespace dypho {

namespace {
constexpr float kShC0 = 0.28209479177387814f;
}

float RgbToShDc(float c) { return (c - 0.5f) / kShC0; }
float ShDcToRgb(float coeff) { return coeff * kShC0 + 0.5f; }

void GaussianCloud::Add(const float mean[3], const float log_scale[3], const float quat[4], float opacity_logit,
                        const float* coeffs) {
  means.insert(means.end(), mean, mean + 3);
  log_scales.insert(log_scales.end(), log_scale, log_scale + 3);
  quats.insert(quats.end(), quat, quat + 4);
  opacity_logits.push_back(opacity_logit);
  sh.insert(sh.end(), coeffs, coeffs + 3 * sh_coeffs);
}

void GaussianCloud::Validate(const std::string& what) const {
  const size_t n = opacity_logits.size();
  DYPHO_CHECK_INPUT(sh_coeffs == 1 || sh_coeffs == 4 || sh_coeffs == 9 || sh_coeffs == 16)
      << what << ": sh_coeffs must be 1, 4, 9 or 16 (got " << sh_coeffs << ")";
  DYPHO_CHECK_INPUT(means.size() == 3 * n) << what << ": means has " << means.size() << " values, expected " << 3 * n;
  DYPHO_CHECK_INPUT(log_scales.size() == 3 * n)
      << what << ": log_scales has " << log_scales.size() << " values, expected " << 3 * n;
  DYPHO_CHECK_INPUT(quats.size() == 4 * n) << what << ": quats has " << quats.size() << " values, expected " << 4 * n;
  DYPHO_CHECK_INPUT(sh.size() == 3 * sh_coeffs * n)
      << what << ": sh has " << sh.size() << " values, expected " << 3 * sh_coeffs * n;
}

kernels::GaussianParams GaussianCloud::params() const {
  kernels::GaussianParams p;
  p.means = means.data();
  p.log_scales = log_scales.data();
  p.quats = quats.data();
  p.opacity_logits = opacity_logits.data();
  p.sh = sh.data();
  p.num_gaussians = size();
  p.sh_coeffs = sh_coeffs;
  return p;
}

}  // namespace dypho
