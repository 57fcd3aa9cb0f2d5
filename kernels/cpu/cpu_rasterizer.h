// CPU reference backend. Multi-threaded (OpenMP) and deterministic: the
// output is bit-identical for any thread count, because every parallel loop
// writes disjoint memory and every reduction runs in a fixed order:
// - preprocessing is per Gaussian;
// - each tile's list is built by the thread that owns its tile row, walking
//   the Gaussians in (depth, index) order, so each list is depth-sorted;
// - the backward pass gives every (Gaussian, tile row) pair its own
//   accumulator, filled left to right by one thread, then sums them per
//   Gaussian in row order; the pose gradient is summed in fixed chunks.
// Templated on the scalar so tests can run it in double precision.
#pragma once

#include <memory>

#include "kernels/rasterizer.h"

namespace dypho::kernels::cpu {

template <typename T>
std::unique_ptr<RasterState> Forward(const GaussianParamsT<T>& params, const RasterCamera& camera,
                                     const RasterSettings& settings, const RasterOutputsT<T>& outputs);

template <typename T>
void Backward(const RasterState& state, const GaussianParamsT<T>& params, const RasterCamera& camera,
              const RasterSettings& settings, const RasterOutputGradsT<T>& output_grads,
              const GaussianGradsT<T>& grads);

std::unique_ptr<Rasterizer> CreateCpuRasterizer();

}  // namespace dypho::kernels::cpu
