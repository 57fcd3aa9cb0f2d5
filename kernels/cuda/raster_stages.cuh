// The stages of the CUDA rasterizer (nvcc only), split by stage and direction
// like gsplat: each stage is a host function in its own .cu file that launches
// that file's kernels on the default stream. All pointers are device pointers;
// shapes are in the comments (N Gaussians, P (Gaussian, tile) pairs, H x W
// pixels, tiles_x x tiles_y tiles of kTileSize x kTileSize pixels).
//
// Forward:  ProjectForward -> CountTilePairs -> (host reads the pair count)
//           -> BinTilePairs -> RasterizeForward
// Backward: RasterizeBackward -> ProjectBackward
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

// GLM 0.9.9.8 marks its defaulted constructors __host__ __device__, which
// nvcc reports as warning 20012 (harmless: defaulted functions are usable on
// both sides). Silenced for GLM's headers only.
#pragma nv_diag_suppress 20012
#include <glm/glm.hpp>
#pragma nv_diag_default 20012

#include "kernels/cuda/device_array.h"
#include "kernels/math/preprocess.h"
#include "kernels/rasterizer.h"

namespace dypho::kernels::cuda {

using CameraData = math::CameraData<float>;

constexpr int kBlockPixels = kTileSize * kTileSize;  // threads per tile block: one per pixel
constexpr int kGaussianBlock = 256;                  // threads per block of per-Gaussian kernels
constexpr int kWarpSize = 32;
constexpr unsigned kFullWarp = 0xffffffffu;

// Per-Gaussian screen-space gradients accumulated by RasterizeBackward, one
// row of kScreenGradSize floats per Gaussian ([N, 10]), in the order of
// math::ScreenGrads.
enum ScreenGradIndex : int {
  kGradMeanX = 0,
  kGradMeanY,
  kGradConicA,
  kGradConicB,
  kGradConicC,
  kGradColorR,
  kGradColorG,
  kGradColorB,
  kGradOpacity,
  kGradDepth,
  kScreenGradSize
};

// Counters filled during Forward and read by the host in one copy.
enum ForwardCounter : int { kCountVisible = 0, kCountNonFinite, kCountPairs, kNumForwardCounters };

// What ProjectForward writes per Gaussian (all [N]). For Gaussians that are
// not visible only `status` is meaningful (and `tile_rect` is empty).
struct ProjectedArrays {
  uint8_t* status = nullptr;   // math::ProjectStatus
  uint8_t* clamped = nullptr;  // colour channels clamped at 0 (bit per channel)
  float4* geom = nullptr;      // mean_x, mean_y [px], opacity, power_min
  float4* conic = nullptr;     // A, B, C, camera depth [m]
  float4* color = nullptr;     // r, g, b, order-independent weight f(depth)
  int4* tile_rect = nullptr;   // tile_x0, tile_y0, tile_x1, tile_y1: touched tiles [x0, x1) x [y0, y1)
};

// Per-pixel values Forward keeps for Backward (all [H, W] unless said).
struct PixelState {
  float* transmittance = nullptr;  // sorted: final T; order-independent: P = prod (1 - alpha)
  int32_t* num_contrib = nullptr;  // sorted: tile-list prefix length used (last contributor + 1)
  float* color = nullptr;          // [H, W, 3] sorted: output colour; order-independent: mean colour
  float* depth = nullptr;          // sorted: output depth; order-independent: mean depth
  float* sum_weight = nullptr;     // order-independent: A = sum alpha f
};

// 1. Per Gaussian: math::ProjectGaussian; writes `out`, the radii (when
// non-null, [N]) and adds the visible and non-finite counts to
// counters[kCountVisible], counters[kCountNonFinite].
void ProjectForward(const GaussianParams& params, const CameraData& cam, const ProjectedArrays& out,
                    int32_t* radii, unsigned long long* counters);

// 2. Per Gaussian: the number of tiles its footprint reaches (binned as in
// the CPU backend, see tile_intersect.cu), and the inclusive prefix sum
// `pair_ends` [N]; pair_ends[N-1] is the pair count.
void CountTilePairs(int num_gaussians, const CameraData& cam, const int4* tile_rect, const float4* geom,
                    const float4* conic, DeviceArray<int64_t>* pair_ends);

// 3. Emits the (tile, depth) key and Gaussian id of every pair, sorts them
// (stable radix sort: by tile, then by depth when `by_depth`, ties in index
// order) and finds each tile's range of the sorted list. `sorted_ids` [P],
// `tile_ranges` [tiles] (begin, end); empty tiles get (0, 0).
void BinTilePairs(int num_gaussians, int num_pairs, const CameraData& cam, const int4* tile_rect,
                  const float4* geom, const float4* conic, const int64_t* pair_ends, bool by_depth,
                  DeviceArray<int32_t>* sorted_ids, DeviceArray<int2>* tile_ranges);

// 4. One 16x16 block per tile; writes the outputs and the pixel state.
void RasterizeForward(CompositeMode mode, const CameraData& cam, const float background[3],
                      const int2* tile_ranges, const int32_t* sorted_ids, const float4* geom, const float4* conic,
                      const float4* color, const RasterOutputs& outputs, const PixelState& pixels);

// 5. Per pixel, the VJP of the compositing; accumulates (atomically) into
// `screen_grads` [N, kScreenGradSize], which the caller zeroes.
void RasterizeBackward(CompositeMode mode, const CameraData& cam, const float background[3],
                       const int2* tile_ranges, const int32_t* sorted_ids, const float4* geom, const float4* conic,
                       const float4* color, const PixelState& pixels, const RasterOutputGrads& output_grads,
                       float* screen_grads);

// 6. Per Gaussian: math::ProjectGaussianVjp, writing the parameter gradients
// (zero for Gaussians that are not visible) and v_mean2d_abs; the pose parts
// are reduced on the device and turned into v_cam_twist (when non-null).
void ProjectBackward(const GaussianParams& params, const CameraData& cam, const uint8_t* status,
                     const uint8_t* clamped, const float* screen_grads, const GaussianGrads& grads);

// Warp-wide sum (every lane of the warp must call it); lane 0 holds the total.
template <typename T>
__device__ __forceinline__ T WarpSum(T value) {
#pragma unroll
  for (int offset = kWarpSize / 2; offset > 0; offset /= 2) value += __shfl_down_sync(kFullWarp, value, offset);
  return value;
}

inline int DivUp(int64_t a, int b) { return static_cast<int>((a + b - 1) / b); }

}  // namespace dypho::kernels::cuda
