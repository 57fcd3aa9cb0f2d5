// Stage 5 (backward): the VJP of the per-tile compositing, per pixel.
//
// Same traversal as the CPU backend's BackwardTileSorted / BackwardTileOit:
// - Sorted mode runs front to back over the first num_contrib Gaussians of
//   the pixel's tile list, recomputing T_i and the prefix sums; the suffix
//   sums come from the stored output (S = C - prefix), and
//   math::SortedAlphaGrad gives dL/dalpha_i.
// - Order-independent mode visits every Gaussian of the tile list and uses
//   the stored per-pixel sums with math::OitPixelVjp.
// Then math::SplatAlphaVjp turns dL/dalpha into the screen-space gradients.
// For each Gaussian of a batch, a warp whose pixels it touched sums their
// contributions with shuffles and lane 0 adds them to the Gaussian's row of
// `screen_grads` with atomicAdd (so the sum order, and the last bits, vary
// from run to run).
#include "kernels/cuda/cuda_check.cuh"
#include "kernels/cuda/raster_stages.cuh"
#include "kernels/cuda/tile_block.cuh"

namespace dypho::kernels::cuda {
namespace {

using math::Vec3;

// Warp-reduces one pixel's contribution to Gaussian `gaussian` and adds it to
// its row of screen_grads. Every lane of the warp calls it; warps in which no
// pixel touched the Gaussian skip the reduction.
__device__ __forceinline__ void AddScreenGrads(float (&v)[kScreenGradSize], bool touched, int32_t gaussian,
                                               int lane, float* __restrict__ screen_grads) {
  if (!__any_sync(kFullWarp, touched)) return;
#pragma unroll
  for (int c = 0; c < kScreenGradSize; ++c) v[c] = WarpSum(v[c]);
  if (lane == 0) {
    float* row = screen_grads + static_cast<size_t>(kScreenGradSize) * gaussian;
#pragma unroll
    for (int c = 0; c < kScreenGradSize; ++c) atomicAdd(row + c, v[c]);
  }
}

__device__ __forceinline__ Vec3<float> LoadVec3(const float* __restrict__ p, size_t o) {
  return Vec3<float>(p[3 * o], p[3 * o + 1], p[3 * o + 2]);
}

__global__ void __launch_bounds__(kBlockPixels)
    RasterizeBackwardSortedKernel(int width, int height, int tiles_x,
                                  const int2* __restrict__ tile_ranges,         // [tiles]
                                  const int32_t* __restrict__ sorted_ids,       // [P]
                                  const float4* __restrict__ geom,              // [N]
                                  const float4* __restrict__ conic,             // [N]
                                  const float4* __restrict__ color,             // [N]
                                  const float* __restrict__ pix_transmittance,  // [H, W] final T
                                  const int32_t* __restrict__ pix_num_contrib,  // [H, W]
                                  const float* __restrict__ pix_color,          // [H, W, 3] output colour
                                  const float* __restrict__ pix_depth,          // [H, W] output depth
                                  const float* __restrict__ v_out_color,        // [H, W, 3] or null
                                  const float* __restrict__ v_out_depth,        // [H, W] or null
                                  const float* __restrict__ v_out_alpha,        // [H, W] or null
                                  float* __restrict__ screen_grads) {           // [N, kScreenGradSize]
  __shared__ int32_t s_id[kBlockPixels];
  __shared__ float4 s_geom[kBlockPixels];
  __shared__ float4 s_conic[kBlockPixels];
  __shared__ float4 s_color[kBlockPixels];
  __shared__ int s_max_contrib;

  const TilePixel pixel = ThisTilePixel(width, height, tiles_x);
  const int tile = pixel.tile, tid = pixel.tid;
  const int lane = tid % kWarpSize;
  const bool inside = pixel.inside;
  const float fx = pixel.fx, fy = pixel.fy;

  // This pixel's forward results and cotangents.
  int32_t last = 0;
  float final_trans = 1.f, out_depth = 0.f, v_depth = 0.f, v_alpha_out = 0.f;
  Vec3<float> out_color(0.f), v_color(0.f);
  if (inside) {
    const size_t o = pixel.offset;
    last = pix_num_contrib[o];
    final_trans = pix_transmittance[o];
    out_color = LoadVec3(pix_color, o);
    out_depth = pix_depth[o];
    if (v_out_color != nullptr) v_color = LoadVec3(v_out_color, o);
    if (v_out_depth != nullptr) v_depth = v_out_depth[o];
    if (v_out_alpha != nullptr) v_alpha_out = v_out_alpha[o];
  }
  if (tid == 0) s_max_contrib = 0;
  __syncthreads();
  if (last > 0) atomicMax(&s_max_contrib, last);
  __syncthreads();

  const int2 range = tile_ranges[tile];
  const int num = s_max_contrib;  // <= range.y - range.x
  float trans = 1.f;
  Vec3<float> pre_color(0.f);
  float pre_depth = 0.f;

  for (int base = 0; base < num; base += kBlockPixels) {
    __syncthreads();  // the previous batch is no longer read
    s_id[tid] = LoadSplatBatch(base, tid, num, range, sorted_ids, geom, conic, color, s_geom, s_conic, s_color);
    __syncthreads();
    const int count = min(kBlockPixels, num - base);
    for (int k = 0; k < count; ++k) {
      float v[kScreenGradSize] = {};
      bool touched = false;
      if (base + k < last) {
        const float4 gm = s_geom[k];   // mean_x, mean_y, opacity, power_min
        const float4 cn = s_conic[k];  // A, B, C, depth
        const float dx = fx - gm.x, dy = fy - gm.y;
        const float power = math::SplatPower(cn.x, cn.y, cn.z, dx, dy);
        if (power >= gm.w) {
          touched = true;
          const float4 cl = s_color[k];
          const Vec3<float> c(cl.x, cl.y, cl.z);
          const float alpha = math::SplatAlpha(gm.z, power);
          const float w = alpha * trans;
          pre_color.x += w * c.x;
          pre_color.y += w * c.y;
          pre_color.z += w * c.z;
          pre_depth += w * cn.w;
          const Vec3<float> suffix_color = out_color - pre_color;
          const float suffix_depth = out_depth - pre_depth;
          const float v_a = math::SortedAlphaGrad(alpha, trans, c, cn.w, suffix_color, suffix_depth, final_trans,
                                                  v_color, v_depth, v_alpha_out);
          v[kGradColorR] = w * v_color.x;
          v[kGradColorG] = w * v_color.y;
          v[kGradColorB] = w * v_color.z;
          v[kGradDepth] = w * v_depth;
          math::SplatAlphaVjp(gm.z, power, cn.x, cn.y, cn.z, dx, dy, v_a, &v[kGradOpacity], &v[kGradConicA],
                              &v[kGradConicB], &v[kGradConicC], &v[kGradMeanX], &v[kGradMeanY]);
          trans *= 1.f - alpha;
        }
      }
      AddScreenGrads(v, touched, s_id[k], lane, screen_grads);
    }
  }
}

__global__ void __launch_bounds__(kBlockPixels)
    RasterizeBackwardOitKernel(int width, int height, int tiles_x, float3 background,
                               const int2* __restrict__ tile_ranges,         // [tiles]
                               const int32_t* __restrict__ sorted_ids,       // [P]
                               const float4* __restrict__ geom,              // [N]
                               const float4* __restrict__ conic,             // [N]
                               const float4* __restrict__ color,             // [N]
                               const float* __restrict__ pix_transmittance,  // [H, W] P
                               const float* __restrict__ pix_sum_weight,     // [H, W] A
                               const float* __restrict__ pix_mean_color,     // [H, W, 3]
                               const float* __restrict__ pix_mean_depth,     // [H, W]
                               const float* __restrict__ v_out_color,        // [H, W, 3] or null
                               const float* __restrict__ v_out_depth,        // [H, W] or null
                               const float* __restrict__ v_out_alpha,        // [H, W] or null
                               float* __restrict__ screen_grads) {           // [N, kScreenGradSize]
  __shared__ int32_t s_id[kBlockPixels];
  __shared__ float4 s_geom[kBlockPixels];
  __shared__ float4 s_conic[kBlockPixels];
  __shared__ float4 s_color[kBlockPixels];
  __shared__ float2 s_weight[kBlockPixels];  // f(depth), df/ddepth

  const TilePixel pixel = ThisTilePixel(width, height, tiles_x);
  const int tile = pixel.tile, tid = pixel.tid;
  const int lane = tid % kWarpSize;
  const bool inside = pixel.inside;
  const float fx = pixel.fx, fy = pixel.fy;
  const Vec3<float> bg(background.x, background.y, background.z);

  float prod = 1.f, sum_w = 0.f, mean_depth = 0.f, v_depth = 0.f, v_alpha_out = 0.f;
  Vec3<float> mean_color(0.f), v_color(0.f);
  if (inside) {
    const size_t o = pixel.offset;
    prod = pix_transmittance[o];
    sum_w = pix_sum_weight[o];
    mean_color = LoadVec3(pix_mean_color, o);
    mean_depth = pix_mean_depth[o];
    if (v_out_color != nullptr) v_color = LoadVec3(v_out_color, o);
    if (v_out_depth != nullptr) v_depth = v_out_depth[o];
    if (v_out_alpha != nullptr) v_alpha_out = v_out_alpha[o];
  }

  const int2 range = tile_ranges[tile];
  const int num = range.y - range.x;
  for (int base = 0; base < num; base += kBlockPixels) {
    __syncthreads();  // the previous batch is no longer read
    const int32_t g =
        LoadSplatBatch(base, tid, num, range, sorted_ids, geom, conic, color, s_geom, s_conic, s_color);
    s_id[tid] = g;
    if (g >= 0) {
      float dfdz;
      const float f = math::OitWeight(s_conic[tid].w, &dfdz);
      s_weight[tid] = make_float2(f, dfdz);
    }
    __syncthreads();
    const int count = min(kBlockPixels, num - base);
    for (int k = 0; k < count; ++k) {
      float v[kScreenGradSize] = {};
      bool touched = false;
      if (inside) {
        const float4 gm = s_geom[k];
        const float4 cn = s_conic[k];
        const float dx = fx - gm.x, dy = fy - gm.y;
        const float power = math::SplatPower(cn.x, cn.y, cn.z, dx, dy);
        if (power >= gm.w) {
          touched = true;
          const float4 cl = s_color[k];
          const float2 fw = s_weight[k];
          const float alpha = math::SplatAlpha(gm.z, power);
          Vec3<float> v_c(0.f);
          float v_a = 0.f, v_z = 0.f;
          math::OitPixelVjp(alpha, Vec3<float>(cl.x, cl.y, cl.z), cn.w, fw.x, fw.y, sum_w, prod, mean_color,
                            mean_depth, bg, v_color, v_depth, v_alpha_out, &v_c, &v_a, &v_z);
          v[kGradColorR] = v_c.x;
          v[kGradColorG] = v_c.y;
          v[kGradColorB] = v_c.z;
          v[kGradDepth] = v_z;
          math::SplatAlphaVjp(gm.z, power, cn.x, cn.y, cn.z, dx, dy, v_a, &v[kGradOpacity], &v[kGradConicA],
                              &v[kGradConicB], &v[kGradConicC], &v[kGradMeanX], &v[kGradMeanY]);
        }
      }
      AddScreenGrads(v, touched, s_id[k], lane, screen_grads);
    }
  }
}

}  // namespace

void RasterizeBackward(CompositeMode mode, const CameraData& cam, const float background[3],
                       const int2* tile_ranges, const int32_t* sorted_ids, const float4* geom, const float4* conic,
                       const float4* color, const PixelState& pixels, const RasterOutputGrads& output_grads,
                       float* screen_grads) {
  const dim3 grid(cam.tiles_x, cam.tiles_y);
  const dim3 block(kTileSize, kTileSize);
  if (mode == CompositeMode::kSorted) {
    RasterizeBackwardSortedKernel<<<grid, block>>>(cam.width, cam.height, cam.tiles_x, tile_ranges, sorted_ids,
                                                   geom, conic, color, pixels.transmittance, pixels.num_contrib,
                                                   pixels.color, pixels.depth, output_grads.v_color,
                                                   output_grads.v_depth, output_grads.v_alpha, screen_grads);
    DYPHO_CUDA_CHECK_LAUNCH("RasterizeBackwardSortedKernel");
  } else {
    const float3 bg = make_float3(background[0], background[1], background[2]);
    RasterizeBackwardOitKernel<<<grid, block>>>(cam.width, cam.height, cam.tiles_x, bg, tile_ranges, sorted_ids,
                                                geom, conic, color, pixels.transmittance, pixels.sum_weight,
                                                pixels.color, pixels.depth, output_grads.v_color,
                                                output_grads.v_depth, output_grads.v_alpha, screen_grads);
    DYPHO_CUDA_CHECK_LAUNCH("RasterizeBackwardOitKernel");
  }
}

}  // namespace dypho::kernels::cuda
