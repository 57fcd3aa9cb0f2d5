// Scenes and image comparisons shared by the Vulkan renderer tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/dataset/dataset.h"
#include "engine/gaussians.h"
#include "engine/render/render.h"

namespace dypho::testing {

// `n` random Gaussians in a box 1.5..5 m in front of the identity camera,
// random anisotropic scales, rotations, opacities and SH of `sh_coeffs`.
inline GaussianCloud RandomCloud(int n, int sh_coeffs, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, 1.0f);
  GaussianCloud cloud;
  cloud.sh_coeffs = sh_coeffs;
  std::vector<float> coeffs(3 * sh_coeffs);
  for (int i = 0; i < n; ++i) {
    const float z = 1.5f + 3.5f * u(rng);
    const float mean[3] = {(u(rng) - 0.5f) * 1.4f * z, (u(rng) - 0.5f) * 1.1f * z, z};
    const float base = std::log(0.01f + 0.08f * u(rng));
    const float log_scale[3] = {base + 0.5f * g(rng), base + 0.5f * g(rng), base + 0.5f * g(rng)};
    const float quat[4] = {g(rng), g(rng), g(rng), g(rng)};
    const float logit = -1.0f + 4.0f * u(rng);
    for (int c = 0; c < 3; ++c) coeffs[c] = RgbToShDc(0.1f + 0.8f * u(rng));
    for (int k = 3; k < 3 * sh_coeffs; ++k) coeffs[k] = 0.15f * g(rng);
    cloud.Add(mean, log_scale, quat, logit, coeffs.data());
  }
  return cloud;
}

// A map from a real RGB-D frame: one isotropic Gaussian per `step` x `step`
// pixels at the unprojected depth, scale ~ depth * step / fx, the pixel's
// colour, opacity logit 2.
inline GaussianCloud CloudFromFrame(const Frame& frame, const Camera& camera, int step) {
  GaussianCloud cloud;
  cloud.sh_coeffs = 1;
  for (int y = step / 2; y < frame.depth.height(); y += step) {
    for (int x = step / 2; x < frame.depth.width(); x += step) {
      const float d = frame.depth.at(x, y);
      if (!(d > 0.1f)) continue;
      const Eigen::Vector3d p = camera.Unproject(Eigen::Vector2d(x, y), d);
      const float mean[3] = {float(p.x()), float(p.y()), float(p.z())};
      const float s = std::log(0.6f * d * step / float(camera.fx));
      const float log_scale[3] = {s, s, s};
      const float quat[4] = {1, 0, 0, 0};
      float coeffs[3];
      for (int c = 0; c < 3; ++c) coeffs[c] = RgbToShDc(frame.rgb.at(x, y, c) / 255.0f);
      cloud.Add(mean, log_scale, quat, 2.0f, coeffs);
    }
  }
  return cloud;
}

// PSNR [dB] of two float images over all channels, values clamped to [0, 1].
inline double Psnr(const ImageF& a, const ImageF& b) {
  double se = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = std::clamp(a.data()[i], 0.0f, 1.0f) - std::clamp(b.data()[i], 0.0f, 1.0f);
    se += d * d;
  }
  const double mse = se / std::max<size_t>(1, a.size());
  return mse <= 0 ? 200.0 : 10.0 * std::log10(1.0 / mse);
}

struct DepthAgreement {
  int compared = 0;    // pixels with alpha > 0.5 in both images
  int within = 0;      // of those, |d_a - d_b| <= rel * d_b (normalised depth)
  double max_rel = 0;  // largest relative difference
};

// Normalised depth (depth / alpha) of `a` against the reference `b`.
inline DepthAgreement CompareDepth(const RenderedView& a, const RenderedView& b, double rel) {
  DepthAgreement r;
  for (size_t i = 0; i < a.depth.size(); ++i) {
    const float aa = a.alpha.data()[i], ab = b.alpha.data()[i];
    if (!(aa > 0.5f && ab > 0.5f)) continue;
    const double da = a.depth.data()[i] / aa, db = b.depth.data()[i] / ab;
    const double e = std::abs(da - db) / db;
    ++r.compared;
    r.within += e <= rel;
    r.max_rel = std::max(r.max_rel, e);
  }
  return r;
}

inline double MaxAbsDiff(const ImageF& a, const ImageF& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, double(std::abs(a.data()[i] - b.data()[i])));
  return m;
}

}  // namespace dypho::testing
