// The sensor model's image warp (engine/map/sensor_model.h) as a LibTorch
// autograd function for the mapper: out(q) = 1/N sum_j bilinear(image,
// H[j, row(q)] q) with zeros outside the image. A plain CPU loop (rows in
// parallel; the backward pass scatters into per-thread buffers) replaces
// torch::grid_sample, whose CPU backward made a mapping step about 40% slower
// with 9 samples (measured with perf on tum_fr1_rpy_head250). Other devices
// fall back to grid_sample with the same result.
#pragma once

#include <torch/torch.h>

namespace dypho {

// image [h, w, c] float; homographies [n, h, 3, 3] float: for sample j and
// row y, the map from an output pixel (x, y, 1) to the homogeneous image pixel
// it reads (pixel centres at integers; engine/map/sensor_model.h
// SensorRowHomographies). Differentiable with respect to the image.
torch::Tensor SensorWarp(const torch::Tensor& image, const torch::Tensor& homographies);

}  // namespace dypho
