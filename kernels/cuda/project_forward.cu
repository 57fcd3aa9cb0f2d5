// Stage 1 of the forward pass: per-Gaussian projection (math::ProjectGaussian,
// the CPU backend's code) into the screen-space arrays the later stages read.
#include "kernels/cuda/cuda_check.cuh"
#include "kernels/cuda/raster_stages.cuh"

namespace dypho::kernels::cuda {
namespace {

__global__ void __launch_bounds__(kGaussianBlock)
    ProjectForwardKernel(int num_gaussians,
                         const float* __restrict__ means,              // [N, 3]
                         const float* __restrict__ log_scales,         // [N, 3]
                         const float* __restrict__ quats,              // [N, 4]
                         const float* __restrict__ opacity_logits,     // [N]
                         const float* __restrict__ sh,                 // [N, K, 3]
                         int sh_coeffs,                                // K
                         const CameraData cam,                         // math::MakeCameraData<float>
                         uint8_t* __restrict__ status,                 // [N]
                         uint8_t* __restrict__ clamped,                // [N]
                         float4* __restrict__ geom,                    // [N]
                         float4* __restrict__ conic,                   // [N]
                         float4* __restrict__ color,                   // [N]
                         int4* __restrict__ tile_rect,                 // [N]
                         int32_t* __restrict__ radii,                  // [N] or null
                         unsigned long long* __restrict__ counters) {  // [kNumForwardCounters]
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  int result = math::kCulled;
  if (i < num_gaussians) {
    math::Projected<float> p;
    result = math::ProjectGaussian(i, means, log_scales, quats, opacity_logits, sh, sh_coeffs, cam, &p);
    status[i] = static_cast<uint8_t>(result);
    if (result == math::kVisible) {
      float dfdz;
      const float weight = math::OitWeight(p.depth, &dfdz);
      clamped[i] = static_cast<uint8_t>(p.clamped);
      geom[i] = make_float4(p.splat.mean_x, p.splat.mean_y, p.splat.opacity, p.splat.power_min);
      conic[i] = make_float4(p.splat.A, p.splat.B, p.splat.C, p.depth);
      color[i] = make_float4(p.color[0], p.color[1], p.color[2], weight);
      tile_rect[i] = make_int4(p.tile_x0, p.tile_y0, p.tile_x1, p.tile_y1);
    } else {
      clamped[i] = 0;
      geom[i] = make_float4(0.f, 0.f, 0.f, 0.f);
      conic[i] = make_float4(0.f, 0.f, 0.f, 0.f);
      color[i] = make_float4(0.f, 0.f, 0.f, 0.f);
      tile_rect[i] = make_int4(0, 0, 0, 0);  // empty: no tile
    }
    if (radii != nullptr) radii[i] = result == math::kVisible ? p.radius : 0;
  }
  // Block totals first (every thread of the block reaches these), then one
  // atomic per block and counter.
  const int visible = __syncthreads_count(result == math::kVisible);
  const int nonfinite = __syncthreads_count(result == math::kNonFinite);
  if (threadIdx.x == 0) {
    if (visible > 0) atomicAdd(&counters[kCountVisible], static_cast<unsigned long long>(visible));
    if (nonfinite > 0) atomicAdd(&counters[kCountNonFinite], static_cast<unsigned long long>(nonfinite));
  }
}

}  // namespace

void ProjectForward(const GaussianParams& params, const CameraData& cam, const ProjectedArrays& out,
                    int32_t* radii, unsigned long long* counters) {
  const int n = params.num_gaussians;
  if (n == 0) return;
  ProjectForwardKernel<<<DivUp(n, kGaussianBlock), kGaussianBlock>>>(
      n, params.means, params.log_scales, params.quats, params.opacity_logits, params.sh, params.sh_coeffs, cam,
      out.status, out.clamped, out.geom, out.conic, out.color, out.tile_rect, radii, counters);
  DYPHO_CUDA_CHECK_LAUNCH("ProjectForwardKernel");
}

}  // namespace dypho::kernels::cuda
