#include "engine/torch/mapper_ops.h"

#include <cmath>
#include <vector>

namespace dypho {
namespace {
torch::TensorOptions Float() { return torch::TensorOptions().dtype(torch::kFloat32); }
}  // namespace

// Separable Gaussian window for SSIM (11 taps, sigma 1.5), normalised.
torch::Tensor GaussianWindow1d() {
  std::vector<float> w(11);
  double sum = 0;
  for (int i = 0; i < 11; ++i) {
    w[i] = static_cast<float>(std::exp(-((i - 5) * (i - 5)) / (2.0 * 1.5 * 1.5)));
    sum += w[i];
  }
  for (float& x : w) x = static_cast<float>(x / sum);
  return torch::from_blob(w.data(), {11}, Float()).clone();
}

// Per-pixel SSIM map of two [3, h, w] images (zero padding), [3, h, w].
// The separable 11-tap blur of every channel of x [c, h, w] (zero padding).
torch::Tensor BlurChannels(const torch::Tensor& x, const torch::Tensor& window) {
  namespace F = torch::nn::functional;
  const int64_t c = x.size(0);
  const torch::Tensor wx = window.view({1, 1, 1, 11}).expand({c, 1, 1, 11}).contiguous();
  const torch::Tensor wy = window.view({1, 1, 11, 1}).expand({c, 1, 11, 1}).contiguous();
  torch::Tensor y = F::conv2d(x.unsqueeze(0), wx, F::Conv2dFuncOptions().padding({0, 5}).groups(c));
  y = F::conv2d(y, wy, F::Conv2dFuncOptions().padding({5, 0}).groups(c));
  return y.squeeze(0);
}

// SSIM map of a (rendered, with gradients) against b (the frame, constant).
// The five local statistics are blurred in two batched calls: the frame's
// (no gradient) and the render's (a, a^2, ab).
torch::Tensor SsimMap(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& window) {
  const int64_t c = a.size(0);
  torch::Tensor stats_b;
  {
    torch::NoGradGuard no_grad;
    stats_b = BlurChannels(torch::cat({b, b * b}), window);
  }
  const torch::Tensor stats_a = BlurChannels(torch::cat({a, a * a, a * b}), window);
  const torch::Tensor mu_a = stats_a.slice(0, 0, c), mu_b = stats_b.slice(0, 0, c);
  const torch::Tensor mu_a2 = mu_a * mu_a, mu_b2 = mu_b * mu_b, mu_ab = mu_a * mu_b;
  const torch::Tensor var_a = stats_a.slice(0, c, 2 * c) - mu_a2;
  const torch::Tensor var_b = stats_b.slice(0, c, 2 * c) - mu_b2;
  const torch::Tensor cov = stats_a.slice(0, 2 * c, 3 * c) - mu_ab;
  constexpr double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  return ((2 * mu_ab + c1) * (2 * cov + c2)) / ((mu_a2 + mu_b2 + c1) * (var_a + var_b + c2));
}

// Unit quaternion (w, x, y, z) product a * b, rows.
torch::Tensor QuatMultiply(const torch::Tensor& a, const torch::Tensor& b) {
  const auto aw = a.select(1, 0), ax = a.select(1, 1), ay = a.select(1, 2), az = a.select(1, 3);
  const auto bw = b.select(1, 0), bx = b.select(1, 1), by = b.select(1, 2), bz = b.select(1, 3);
  return torch::stack({aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                       aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw},
                      1);
}

// Rotation matrices [N, 3, 3] of quaternions (w, x, y, z), normalised.
torch::Tensor QuatToMatrix(const torch::Tensor& q_in) {
  const torch::Tensor q = q_in / q_in.norm(2, 1, true).clamp_min(1e-12);
  const auto w = q.select(1, 0), x = q.select(1, 1), y = q.select(1, 2), z = q.select(1, 3);
  return torch::stack({1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                       2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                       2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)},
                      1)
      .view({-1, 3, 3});
}


}  // namespace dypho
