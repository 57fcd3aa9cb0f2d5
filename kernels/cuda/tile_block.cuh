// Device helpers shared by the per-tile kernels of rasterize_forward.cu and
// rasterize_backward.cu (nvcc only): one block of kTileSize x kTileSize
// threads per tile, one thread per pixel, the tile's depth-sorted splats
// streamed through shared memory in batches of kBlockPixels.
#pragma once

#include <cstdint>

#include "kernels/cuda/raster_stages.cuh"

namespace dypho::kernels::cuda {

// This thread's pixel.
struct TilePixel {
  int tile = 0;         // blockIdx.y * tiles_x + blockIdx.x
  int tid = 0;          // thread in the block (row-major in the tile)
  int px = 0, py = 0;   // [px] image column and row
  bool inside = false;  // the tile may reach past the image
  float fx = 0.f, fy = 0.f;
  size_t offset = 0;    // py * width + px, meaningful when inside
};

__device__ __forceinline__ TilePixel ThisTilePixel(int width, int height, int tiles_x) {
  TilePixel p;
  p.tile = blockIdx.y * tiles_x + blockIdx.x;
  p.tid = threadIdx.y * kTileSize + threadIdx.x;
  p.px = blockIdx.x * kTileSize + threadIdx.x;
  p.py = blockIdx.y * kTileSize + threadIdx.y;
  p.inside = p.px < width && p.py < height;
  p.fx = static_cast<float>(p.px);
  p.fy = static_cast<float>(p.py);
  p.offset = static_cast<size_t>(p.py) * width + p.px;
  return p;
}

// Thread `tid` copies entry base + tid of the tile's sorted range (when it is
// below `num`) from the splat arrays ProjectForward wrote ([N]: geom =
// mean_x, mean_y, opacity, power_min; conic = A, B, C, depth; color) to slot
// tid of the shared arrays; returns its Gaussian id, or -1 past the end. The
// caller synchronises before and after.
__device__ __forceinline__ int32_t LoadSplatBatch(int base, int tid, int num, int2 range,
                                                  const int32_t* __restrict__ sorted_ids,
                                                  const float4* __restrict__ geom, const float4* __restrict__ conic,
                                                  const float4* __restrict__ color, float4* s_geom, float4* s_conic,
                                                  float4* s_color) {
  const int j = base + tid;
  if (j >= num) return -1;
  const int32_t g = sorted_ids[range.x + j];
  s_geom[tid] = geom[g];
  s_conic[tid] = conic[g];
  s_color[tid] = color[g];
  return g;
}

}  // namespace dypho::kernels::cuda
