// Random and hand-made Gaussian scenes for rasterizer tests and benchmarks.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "kernels/rasterizer.h"

namespace dypho::testing {

template <typename T>
struct Scene {
  std::vector<T> means, log_scales, quats, opacity_logits, sh;
  int n = 0;
  int sh_coeffs = 1;

  kernels::GaussianParamsT<T> params() const {
    kernels::GaussianParamsT<T> p;
    p.means = means.data();
    p.log_scales = log_scales.data();
    p.quats = quats.data();
    p.opacity_logits = opacity_logits.data();
    p.sh = sh.data();
    p.num_gaussians = n;
    p.sh_coeffs = sh_coeffs;
    return p;
  }
  void Add(const T mean[3], const T log_scale[3], const T quat[4], T logit, const std::vector<T>& coeffs) {
    means.insert(means.end(), mean, mean + 3);
    log_scales.insert(log_scales.end(), log_scale, log_scale + 3);
    quats.insert(quats.end(), quat, quat + 4);
    opacity_logits.push_back(logit);
    sh.insert(sh.end(), coeffs.begin(), coeffs.end());
    ++n;
  }
  // All parameters as one flat list of (array, index) for finite differences.
  std::vector<std::vector<T>*> arrays() { return {&means, &log_scales, &quats, &opacity_logits, &sh}; }
};

// Gaussians in front of an identity camera, spread over the view.
template <typename T>
Scene<T> RandomScene(int n, int sh_coeffs, unsigned seed, double depth_min = 2.0, double depth_max = 4.0,
                     double scale_min = 0.03, double scale_max = 0.15, double logit_min = -1.0,
                     double logit_max = 1.5) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  Scene<T> s;
  s.sh_coeffs = sh_coeffs;
  for (int i = 0; i < n; ++i) {
    const double z = depth_min + (depth_max - depth_min) * u(rng);
    const T mean[3] = {T((u(rng) - 0.5) * 0.9 * z), T((u(rng) - 0.5) * 0.7 * z), T(z)};
    const T ls[3] = {T(std::log(scale_min + (scale_max - scale_min) * u(rng))),
                     T(std::log(scale_min + (scale_max - scale_min) * u(rng))),
                     T(std::log(scale_min + (scale_max - scale_min) * u(rng)))};
    const T q[4] = {T(g(rng)), T(g(rng)), T(g(rng)), T(g(rng))};
    std::vector<T> coeffs(3 * sh_coeffs);
    for (int k = 0; k < 3 * sh_coeffs; ++k) coeffs[k] = T(k < 3 ? u(rng) - 0.3 : 0.3 * g(rng));
    s.Add(mean, ls, q, T(logit_min + (logit_max - logit_min) * u(rng)), coeffs);
  }
  return s;
}

inline kernels::RasterCamera MakeCamera(int width, int height, double f) {
  kernels::RasterCamera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = f;
  c.cx = 0.5 * width - 0.5;
  c.cy = 0.5 * height - 0.5;
  return c;
}

template <typename T>
struct Render {
  std::vector<T> color, depth, alpha;
  std::vector<int32_t> radii;
  Render(int w, int h, int n) : color(size_t(w) * h * 3), depth(size_t(w) * h), alpha(size_t(w) * h), radii(n) {}
  kernels::RasterOutputsT<T> outputs() {
    return {color.data(), depth.data(), alpha.data(), radii.data()};
  }
};

template <typename T>
struct Grads {
  std::vector<T> means, log_scales, quats, opacity_logits, sh, twist, mean2d_abs;
  explicit Grads(const Scene<T>& s)
      : means(3 * s.n), log_scales(3 * s.n), quats(4 * s.n), opacity_logits(s.n), sh(3 * s.sh_coeffs * s.n),
        twist(6), mean2d_abs(s.n) {}
  kernels::GaussianGradsT<T> grads() {
    return {means.data(), log_scales.data(), quats.data(), opacity_logits.data(), sh.data(), twist.data(),
            mean2d_abs.data()};
  }
  std::vector<std::vector<T>*> arrays() { return {&means, &log_scales, &quats, &opacity_logits, &sh}; }
};

}  // namespace dypho::testing
