// Stages 2 and 3 of the forward pass: (Gaussian, tile) pairs.
//
// Binning follows the CPU backend (the binning into tile rows in kernels/cpu/cpu_forward.cc), so
// both backends build the same tile lists up to float rounding of the
// projected footprint: in every tile row of its tile rectangle, a Gaussian is
// listed in the tiles spanned by the exact x-extent of its cut-off ellipse
// within the row's band of pixel centres (math::EllipseBandExtent), for the
// footprint enlarged by math::CullingPowerMin so that
// float rounding never drops a tile holding a pixel that passes the per-pixel
// test. The per-pixel test in the compositing kernels stays the arbiter.
//
// Pairs are counted per Gaussian, prefix-summed (64-bit, so the total cannot
// overflow), emitted as 64-bit keys
//   key = tile << 32 | depth bits      (sorted mode)
//   key = tile << 32                   (order-independent mode)
// with the Gaussian id as value, and radix-sorted. The camera depth is
// positive (>= near_plane > 0), so its IEEE-754 bits order like the floats.
// CUB's radix sort is stable and the pairs are emitted in Gaussian index
// order, so ties (equal depth; every pair of a tile in order-independent mode)
// keep index order, as the CPU backend's stable depth sort does.
#include <climits>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>

#include "kernels/cuda/cuda_check.cuh"
#include "kernels/cuda/raster_stages.cuh"

namespace dypho::kernels::cuda {
namespace {

// The tiles [*tx0, *tx1] (inclusive; empty when *tx0 > *tx1) that Gaussian
// (geom, conic) reaches in tile row `ty`, clipped to its tile rectangle.
// Compiled once (not inlined) so that counting and emitting run the very same
// instructions and always agree on the pair count.
__device__ __noinline__ void TileSpanInRow(float4 geom, float4 conic, int4 rect, int ty, int height, int* tx0,
                                           int* tx1) {
  math::Splat e;
  e.mean_x = geom.x;
  e.mean_y = geom.y;
  e.opacity = geom.z;
  e.power_min = math::CullingPowerMin(geom.w);  // enlarged as in the CPU backend
  e.A = conic.x;
  e.B = conic.y;
  e.C = conic.z;
  const int y0 = ty * kTileSize, y1 = min(y0 + kTileSize, height) - 1;
  float lo, hi;
  int a = 1, b = 0;
  if (math::EllipseBandExtent(e, float(y0) - e.mean_y, float(y1) - e.mean_y, &lo, &hi)) {
    a = max(rect.x, static_cast<int>(floorf((e.mean_x + lo) / float(kTileSize))));
    b = min(rect.z - 1, static_cast<int>(floorf((e.mean_x + hi) / float(kTileSize))));
  }
  *tx0 = a;
  *tx1 = b;
}

__global__ void __launch_bounds__(kGaussianBlock) CountTilePairsKernel(int num_gaussians, int height,
                                                                       const int4* __restrict__ tile_rect,  // [N]
                                                                       const float4* __restrict__ geom,     // [N]
                                                                       const float4* __restrict__ conic,    // [N]
                                                                       int64_t* __restrict__ counts) {      // [N]
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= num_gaussians) return;
  const int4 r = tile_rect[i];
  int64_t count = 0;
  if (r.x < r.z && r.y < r.w) {
    const float4 g = geom[i], c = conic[i];
    for (int ty = r.y; ty < r.w; ++ty) {
      int tx0, tx1;
      TileSpanInRow(g, c, r, ty, height, &tx0, &tx1);
      if (tx1 >= tx0) count += tx1 - tx0 + 1;
    }
  }
  counts[i] = count;
}

__global__ void __launch_bounds__(kGaussianBlock)
    EmitTilePairsKernel(int num_gaussians, int height, int tiles_x, uint32_t sentinel_tile, bool by_depth,
                        const int4* __restrict__ tile_rect,     // [N]
                        const float4* __restrict__ geom,        // [N]
                        const float4* __restrict__ conic,       // [N]
                        const int64_t* __restrict__ pair_ends,  // [N] inclusive prefix sum of the counts
                        uint64_t* __restrict__ keys,            // [P]
                        int32_t* __restrict__ ids) {            // [P]
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= num_gaussians) return;
  int64_t at = i == 0 ? 0 : pair_ends[i - 1];
  const int64_t end = pair_ends[i];
  if (at == end) return;
  const int4 r = tile_rect[i];
  const float4 g = geom[i], c = conic[i];
  const uint64_t depth_bits = by_depth ? static_cast<uint64_t>(__float_as_uint(c.w)) : 0ull;
  for (int ty = r.y; ty < r.w && at < end; ++ty) {
    int tx0, tx1;
    TileSpanInRow(g, c, r, ty, height, &tx0, &tx1);
    for (int tx = tx0; tx <= tx1 && at < end; ++tx) {
      keys[at] = (static_cast<uint64_t>(ty * tiles_x + tx) << 32) | depth_bits;
      ids[at] = i;
      ++at;
    }
  }
  // Unreachable while counting and emitting agree (same function, same
  // inputs); if they ever did not, the slots still hold defined keys that sort
  // after every real tile and are ignored by the range kernel.
  for (; at < end; ++at) {
    keys[at] = static_cast<uint64_t>(sentinel_tile) << 32;
    ids[at] = i;
  }
}

// Sorted keys -> [begin, end) of each tile. Tiles without pairs keep the
// (0, 0) written by the memset.
__global__ void TileRangesKernel(int num_pairs, uint32_t num_tiles,
                                 const uint64_t* __restrict__ keys,  // [P] sorted
                                 int2* __restrict__ tile_ranges) {   // [tiles]
  const int p = blockIdx.x * blockDim.x + threadIdx.x;
  if (p >= num_pairs) return;
  const uint32_t tile = static_cast<uint32_t>(keys[p] >> 32);
  if (tile >= num_tiles) return;  // sentinel
  if (p == 0 || static_cast<uint32_t>(keys[p - 1] >> 32) != tile) tile_ranges[tile].x = p;
  if (p == num_pairs - 1 || static_cast<uint32_t>(keys[p + 1] >> 32) != tile) tile_ranges[tile].y = p + 1;
}

// Bits needed for the values 0..max_value.
int BitWidth(uint32_t max_value) {
  int bits = 0;
  while (bits < 32 && (uint64_t{1} << bits) <= max_value) ++bits;
  return bits;
}

}  // namespace

void CountTilePairs(int num_gaussians, const CameraData& cam, const int4* tile_rect, const float4* geom,
                    const float4* conic, DeviceArray<int64_t>* pair_ends) {
  const int n = num_gaussians;
  pair_ends->Resize(n);
  if (n == 0) return;
  DeviceArray<int64_t> counts(n);
  CountTilePairsKernel<<<DivUp(n, kGaussianBlock), kGaussianBlock>>>(n, cam.height, tile_rect, geom, conic,
                                                                     counts.data());
  DYPHO_CUDA_CHECK_LAUNCH("CountTilePairsKernel");
  size_t temp_bytes = 0;
  DYPHO_CUDA_CHECK(cub::DeviceScan::InclusiveSum(nullptr, temp_bytes, counts.data(), pair_ends->data(), n));
  DeviceArray<unsigned char> temp(temp_bytes);
  DYPHO_CUDA_CHECK(cub::DeviceScan::InclusiveSum(temp.data(), temp_bytes, counts.data(), pair_ends->data(), n));
}

void BinTilePairs(int num_gaussians, int num_pairs, const CameraData& cam, const int4* tile_rect,
                  const float4* geom, const float4* conic, const int64_t* pair_ends, bool by_depth,
                  DeviceArray<int32_t>* sorted_ids, DeviceArray<int2>* tile_ranges) {
  const int num_tiles = cam.tiles_x * cam.tiles_y;
  tile_ranges->Resize(num_tiles);
  tile_ranges->Zero();
  sorted_ids->Resize(num_pairs);
  if (num_pairs == 0) return;

  // Emit.
  DeviceArray<uint64_t> keys(num_pairs), keys_alt(num_pairs);
  DeviceArray<int32_t> ids_alt(num_pairs);
  const uint32_t sentinel_tile = static_cast<uint32_t>(num_tiles);
  EmitTilePairsKernel<<<DivUp(num_gaussians, kGaussianBlock), kGaussianBlock>>>(
      num_gaussians, cam.height, cam.tiles_x, sentinel_tile, by_depth, tile_rect, geom, conic, pair_ends,
      keys.data(), sorted_ids->data());
  DYPHO_CUDA_CHECK_LAUNCH("EmitTilePairsKernel");

  // Sort: only the bits that can be set (the tile bits, plus the depth bits in
  // sorted mode).
  const int begin_bit = by_depth ? 0 : 32;
  const int end_bit = 32 + BitWidth(sentinel_tile);
  cub::DoubleBuffer<uint64_t> key_buffers(keys.data(), keys_alt.data());
  cub::DoubleBuffer<int32_t> id_buffers(sorted_ids->data(), ids_alt.data());
  size_t temp_bytes = 0;
  DYPHO_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, temp_bytes, key_buffers, id_buffers, num_pairs,
                                                   begin_bit, end_bit));
  DeviceArray<unsigned char> temp(temp_bytes);
  DYPHO_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp.data(), temp_bytes, key_buffers, id_buffers, num_pairs,
                                                   begin_bit, end_bit));
  // The sorted ids may sit in either buffer; keep that one.
  if (id_buffers.Current() != sorted_ids->data()) sorted_ids->swap(ids_alt);

  // Ranges.
  TileRangesKernel<<<DivUp(num_pairs, 256), 256>>>(num_pairs, static_cast<uint32_t>(num_tiles),
                                                   key_buffers.Current(), tile_ranges->data());
  DYPHO_CUDA_CHECK_LAUNCH("TileRangesKernel");
}

}  // namespace dypho::kernels::cuda
