// Stage 4 of the forward pass: per-tile compositing.
//
// One 16x16 thread block per tile, one thread per pixel. The tile's sorted
// Gaussians are fetched in batches of kBlockPixels into shared memory (one
// Gaussian per thread), then every thread walks the batch for its pixel with
// the CPU backend's per-pixel semantics (math::SplatPower, the power_min test,
// math::SplatAlpha). Threads of pixels outside the image stay in the loop
// (they load and synchronise) but never composite.
#include "kernels/cuda/cuda_check.cuh"
#include "kernels/cuda/raster_stages.cuh"
#include "kernels/cuda/tile_block.cuh"

namespace dypho::kernels::cuda {
namespace {

// Sorted mode: front to back; a Gaussian that would bring T below
// math::kMinTransmittance is not composited and ends the pixel. The block
// stops fetching when every pixel has ended (__syncthreads_count).
__global__ void __launch_bounds__(kBlockPixels)
    RasterizeSortedKernel(int width, int height, int tiles_x, float3 background,
                          const int2* __restrict__ tile_ranges,    // [tiles]
                          const int32_t* __restrict__ sorted_ids,  // [P]
                          const float4* __restrict__ geom,         // [N]
                          const float4* __restrict__ conic,        // [N]
                          const float4* __restrict__ color,        // [N]
                          float* __restrict__ out_color,           // [H, W, 3]
                          float* __restrict__ out_depth,           // [H, W]
                          float* __restrict__ out_alpha,           // [H, W]
                          float* __restrict__ pix_transmittance,   // [H, W]
                          int32_t* __restrict__ pix_num_contrib,   // [H, W]
                          float* __restrict__ pix_color,           // [H, W, 3]
                          float* __restrict__ pix_depth) {         // [H, W]
  __shared__ float4 s_geom[kBlockPixels];
  __shared__ float4 s_conic[kBlockPixels];
  __shared__ float4 s_color[kBlockPixels];

  const TilePixel pixel = ThisTilePixel(width, height, tiles_x);
  const int tile = pixel.tile, tid = pixel.tid;
  const bool inside = pixel.inside;
  const float fx = pixel.fx, fy = pixel.fy;

  const int2 range = tile_ranges[tile];
  const int num = range.y - range.x;
  bool done = !inside;
  float trans = 1.f;
  float acc_r = 0.f, acc_g = 0.f, acc_b = 0.f, acc_depth = 0.f;
  int32_t last = 0;

  for (int base = 0; base < num; base += kBlockPixels) {
    // Also the barrier that keeps the previous batch in shared memory until
    // every thread has used it.
    if (__syncthreads_count(done) == kBlockPixels) break;
    LoadSplatBatch(base, tid, num, range, sorted_ids, geom, conic, color, s_geom, s_conic, s_color);
    __syncthreads();
    const int count = min(kBlockPixels, num - base);
    for (int k = 0; k < count && !done; ++k) {
      const float4 gm = s_geom[k];   // mean_x, mean_y, opacity, power_min
      const float4 cn = s_conic[k];  // A, B, C, depth
      const float dx = fx - gm.x, dy = fy - gm.y;
      const float power = math::SplatPower(cn.x, cn.y, cn.z, dx, dy);
      if (power < gm.w) continue;
      const float alpha = math::SplatAlpha(gm.z, power);
      const float next = trans * (1.f - alpha);
      if (next < math::kMinTransmittance) {
        done = true;
        break;
      }
      const float w = alpha * trans;
      const float4 c = s_color[k];
      acc_r += w * c.x;
      acc_g += w * c.y;
      acc_b += w * c.z;
      acc_depth += w * cn.w;
      trans = next;
      last = base + k + 1;
    }
  }

  if (!inside) return;
  const size_t o = pixel.offset;
  const float r = acc_r + trans * background.x;
  const float g = acc_g + trans * background.y;
  const float b = acc_b + trans * background.z;
  out_color[3 * o] = r;
  out_color[3 * o + 1] = g;
  out_color[3 * o + 2] = b;
  out_depth[o] = acc_depth;
  out_alpha[o] = 1.f - trans;
  pix_color[3 * o] = r;
  pix_color[3 * o + 1] = g;
  pix_color[3 * o + 2] = b;
  pix_depth[o] = acc_depth;
  pix_transmittance[o] = trans;
  pix_num_contrib[o] = last;
}

// Order-independent mode: every contributing Gaussian is summed (no order, no
// early termination); the per-pixel sums are kept for the backward pass.
__global__ void __launch_bounds__(kBlockPixels)
    RasterizeOitKernel(int width, int height, int tiles_x, float3 background,
                       const int2* __restrict__ tile_ranges,    // [tiles]
                       const int32_t* __restrict__ sorted_ids,  // [P]
                       const float4* __restrict__ geom,         // [N]
                       const float4* __restrict__ conic,        // [N]
                       const float4* __restrict__ color,        // [N] r, g, b, weight f(depth)
                       float* __restrict__ out_color,           // [H, W, 3]
                       float* __restrict__ out_depth,           // [H, W]
                       float* __restrict__ out_alpha,           // [H, W]
                       float* __restrict__ pix_transmittance,   // [H, W] P
                       float* __restrict__ pix_sum_weight,      // [H, W] A
                       float* __restrict__ pix_mean_color,      // [H, W, 3]
                       float* __restrict__ pix_mean_depth) {    // [H, W]
  __shared__ float4 s_geom[kBlockPixels];
  __shared__ float4 s_conic[kBlockPixels];
  __shared__ float4 s_color[kBlockPixels];

  const TilePixel pixel = ThisTilePixel(width, height, tiles_x);
  const int tile = pixel.tile, tid = pixel.tid;
  const bool inside = pixel.inside;
  const float fx = pixel.fx, fy = pixel.fy;

  const int2 range = tile_ranges[tile];
  const int num = range.y - range.x;
  float sum_w = 0.f, prod = 1.f;
  float wr = 0.f, wg = 0.f, wb = 0.f, wdepth = 0.f;

  for (int base = 0; base < num; base += kBlockPixels) {
    __syncthreads();  // the previous batch is no longer read
    LoadSplatBatch(base, tid, num, range, sorted_ids, geom, conic, color, s_geom, s_conic, s_color);
    __syncthreads();
    if (!inside) continue;
    const int count = min(kBlockPixels, num - base);
    for (int k = 0; k < count; ++k) {
      const float4 gm = s_geom[k];
      const float4 cn = s_conic[k];
      const float dx = fx - gm.x, dy = fy - gm.y;
      const float power = math::SplatPower(cn.x, cn.y, cn.z, dx, dy);
      if (power < gm.w) continue;
      const float alpha = math::SplatAlpha(gm.z, power);
      const float4 c = s_color[k];
      const float w = alpha * c.w;
      sum_w += w;
      wr += w * c.x;
      wg += w * c.y;
      wb += w * c.z;
      wdepth += w * cn.w;
      prod *= 1.f - alpha;
    }
  }

  if (!inside) return;
  const size_t o = pixel.offset;
  const float mean_r = sum_w > 0.f ? wr / sum_w : 0.f;
  const float mean_g = sum_w > 0.f ? wg / sum_w : 0.f;
  const float mean_b = sum_w > 0.f ? wb / sum_w : 0.f;
  const float mean_depth = sum_w > 0.f ? wdepth / sum_w : 0.f;
  out_color[3 * o] = mean_r * (1.f - prod) + prod * background.x;
  out_color[3 * o + 1] = mean_g * (1.f - prod) + prod * background.y;
  out_color[3 * o + 2] = mean_b * (1.f - prod) + prod * background.z;
  out_depth[o] = mean_depth * (1.f - prod);
  out_alpha[o] = 1.f - prod;
  pix_transmittance[o] = prod;
  pix_sum_weight[o] = sum_w;
  pix_mean_color[3 * o] = mean_r;
  pix_mean_color[3 * o + 1] = mean_g;
  pix_mean_color[3 * o + 2] = mean_b;
  pix_mean_depth[o] = mean_depth;
}

}  // namespace

void RasterizeForward(CompositeMode mode, const CameraData& cam, const float background[3],
                      const int2* tile_ranges, const int32_t* sorted_ids, const float4* geom, const float4* conic,
                      const float4* color, const RasterOutputs& outputs, const PixelState& pixels) {
  const dim3 grid(cam.tiles_x, cam.tiles_y);
  const dim3 block(kTileSize, kTileSize);
  const float3 bg = make_float3(background[0], background[1], background[2]);
  if (mode == CompositeMode::kSorted) {
    RasterizeSortedKernel<<<grid, block>>>(cam.width, cam.height, cam.tiles_x, bg, tile_ranges, sorted_ids, geom,
                                           conic, color, outputs.color, outputs.depth, outputs.alpha,
                                           pixels.transmittance, pixels.num_contrib, pixels.color, pixels.depth);
    DYPHO_CUDA_CHECK_LAUNCH("RasterizeSortedKernel");
  } else {
    RasterizeOitKernel<<<grid, block>>>(cam.width, cam.height, cam.tiles_x, bg, tile_ranges, sorted_ids, geom,
                                        conic, color, outputs.color, outputs.depth, outputs.alpha,
                                        pixels.transmittance, pixels.sum_weight, pixels.color, pixels.depth);
    DYPHO_CUDA_CHECK_LAUNCH("RasterizeOitKernel");
  }
}

}  // namespace dypho::kernels::cuda
