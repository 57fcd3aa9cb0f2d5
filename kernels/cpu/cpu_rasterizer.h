// CPU reference backend. Multi-threaded (OpenMP) and deterministic: the
// output is bit-identical for any thread count, because every parallel loop
// writes disjoint memory and every reduction runs in a fixed order:
// - preprocessing is per Gaussian; the compositing order (depth, ties by
//   index) comes from a stable sort;
// - one thread owns a tile row: it walks the Gaussians touching the row in
//   compositing order and composites each into the tiles its exact ellipse
//   span reaches, 16 pixels of a row at a time (vectorized); the sorted mode
//   stops walking once every pixel of the row has terminated, so the
//   (Gaussian, tile) pairs behind opaque content are never visited;
// - the backward pass walks the same ranks per tile row and gives every
//   (Gaussian, tile row) pair its own accumulator (16 lanes summed in a fixed
//   order), then sums them per Gaussian in row order; the pose gradient is
//   summed in fixed chunks.
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
