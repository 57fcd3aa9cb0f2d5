// Tensor helpers of the mapper (engine/torch/mapper.cc): the SSIM of the
// colour loss and quaternion algebra on rows of tensors.
#pragma once

#include <torch/torch.h>

namespace dypho {

// Separable Gaussian window for SSIM (11 taps, sigma 1.5), normalised.
torch::Tensor GaussianWindow1d();
// The separable 11-tap blur of every channel of x [c, h, w] (zero padding).
torch::Tensor BlurChannels(const torch::Tensor& x, const torch::Tensor& window);
// Per-pixel SSIM map [c, h, w] of a (rendered, with gradients) against b (the
// frame, constant), both [c, h, w], zero padding (Wang et al. 2004).
torch::Tensor SsimMap(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& window);
// Unit quaternion (w, x, y, z) product a * b, rows [N, 4].
torch::Tensor QuatMultiply(const torch::Tensor& a, const torch::Tensor& b);
// Rotation matrices [N, 3, 3] of quaternions (w, x, y, z) [N, 4], normalised.
torch::Tensor QuatToMatrix(const torch::Tensor& q_in);

}  // namespace dypho
