// Stage 6 (backward): per Gaussian, the screen-space gradients back to the
// parameters and the camera pose (math::ProjectGaussianVjp, the CPU backend's
// code). The per-Gaussian pose parts dL/dR, dL/dt are summed in double
// precision (warp shuffles, then a block sum, then one atomicAdd per block and
// entry) and turned into the twist gradient by math::PoseGradToTwist on the
// device, so Backward never waits for the device.
#include "kernels/cuda/cuda_check.cuh"
#include "kernels/cuda/raster_stages.cuh"

namespace dypho::kernels::cuda {
namespace {

constexpr int kPoseParts = 12;  // dL/dR row-major [3, 3], then dL/dt [3]
constexpr int kWarpsPerGaussianBlock = kGaussianBlock / kWarpSize;

__global__ void __launch_bounds__(kGaussianBlock)
    ProjectBackwardKernel(int num_gaussians,
                          const float* __restrict__ means,           // [N, 3]
                          const float* __restrict__ log_scales,      // [N, 3]
                          const float* __restrict__ quats,           // [N, 4]
                          const float* __restrict__ opacity_logits,  // [N]
                          const float* __restrict__ sh,              // [N, K, 3]
                          int sh_coeffs,                             // K
                          const CameraData cam,                      // math::MakeCameraData<float>
                          const uint8_t* __restrict__ status,        // [N]
                          const uint8_t* __restrict__ clamped,       // [N]
                          const float* __restrict__ screen_grads,    // [N, kScreenGradSize]
                          float* __restrict__ v_means,               // [N, 3] or null
                          float* __restrict__ v_log_scales,          // [N, 3] or null
                          float* __restrict__ v_quats,               // [N, 4] or null
                          float* __restrict__ v_opacity_logits,      // [N] or null
                          float* __restrict__ v_sh,                  // [N, K, 3] or null
                          float* __restrict__ v_mean2d_abs,          // [N] or null
                          double* __restrict__ pose_sums) {          // [kPoseParts] or null
  __shared__ double s_pose[kWarpsPerGaussianBlock][kPoseParts];
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  float pose[kPoseParts] = {};
  if (i < num_gaussians) {
    float v_mean[3] = {}, v_ls[3] = {}, v_q[4] = {}, v_logit = 0.f, mean2d_abs = 0.f;
    float v_sh_local[3 * kMaxShCoeffs] = {};
    if (status[i] == math::kVisible) {
      const float* row = screen_grads + static_cast<size_t>(kScreenGradSize) * i;
      math::ScreenGrads<float> g;
      g.v_mean_x = row[kGradMeanX];
      g.v_mean_y = row[kGradMeanY];
      g.v_A = row[kGradConicA];
      g.v_B = row[kGradConicB];
      g.v_C = row[kGradConicC];
      g.v_color[0] = row[kGradColorR];
      g.v_color[1] = row[kGradColorG];
      g.v_color[2] = row[kGradColorB];
      g.v_opacity = row[kGradOpacity];
      g.v_depth = row[kGradDepth];
      math::Mat3<float> v_R(0.f);
      math::Vec3<float> v_t(0.f);
      math::ProjectGaussianVjp(i, means, log_scales, quats, opacity_logits, sh, sh_coeffs, cam, clamped[i], g,
                               v_mean, v_ls, v_q, &v_logit, v_sh_local, &v_R, &v_t);
      mean2d_abs = sqrtf(g.v_mean_x * g.v_mean_x + g.v_mean_y * g.v_mean_y);
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) pose[3 * r + c] = v_R[c][r];  // GLM is column-major: v_R[col][row]
        pose[9 + r] = v_t[r];
      }
    }
    // Overwrite every output row; Gaussians that are not visible get zeros.
    if (v_means != nullptr) {
      for (int c = 0; c < 3; ++c) v_means[3 * static_cast<size_t>(i) + c] = v_mean[c];
    }
    if (v_log_scales != nullptr) {
      for (int c = 0; c < 3; ++c) v_log_scales[3 * static_cast<size_t>(i) + c] = v_ls[c];
    }
    if (v_quats != nullptr) {
      for (int c = 0; c < 4; ++c) v_quats[4 * static_cast<size_t>(i) + c] = v_q[c];
    }
    if (v_opacity_logits != nullptr) v_opacity_logits[i] = v_logit;
    if (v_sh != nullptr) {
      // ProjectGaussianVjp writes the active coefficients; the rest are zero.
      const int active = 3 * math::ShCoeffsForDegree(cam.sh_degree);
      float* dst = v_sh + static_cast<size_t>(3 * sh_coeffs) * i;
      for (int k = 0; k < 3 * sh_coeffs; ++k) dst[k] = k < active ? v_sh_local[k] : 0.f;
    }
    if (v_mean2d_abs != nullptr) v_mean2d_abs[i] = mean2d_abs;
  }

  if (pose_sums == nullptr) return;  // uniform over the grid
  const int lane = threadIdx.x % kWarpSize, warp = threadIdx.x / kWarpSize;
#pragma unroll
  for (int j = 0; j < kPoseParts; ++j) {
    const double sum = WarpSum(static_cast<double>(pose[j]));
    if (lane == 0) s_pose[warp][j] = sum;
  }
  __syncthreads();
  if (threadIdx.x < kPoseParts) {
    double sum = 0.0;
    for (int w = 0; w < kWarpsPerGaussianBlock; ++w) sum += s_pose[w][threadIdx.x];
    if (sum != 0.0) atomicAdd(&pose_sums[threadIdx.x], sum);
  }
}

// One thread: the summed dL/dR, dL/dt -> the gradient of the left twist.
__global__ void PoseTwistKernel(const CameraData cam, const double* __restrict__ pose_sums,  // [kPoseParts]
                                float* __restrict__ v_cam_twist) {                           // [6]
  math::Mat3<float> v_R;
  math::Vec3<float> v_t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) v_R[c][r] = static_cast<float>(pose_sums[3 * r + c]);
    v_t[r] = static_cast<float>(pose_sums[9 + r]);
  }
  math::PoseGradToTwist(cam.R, cam.t, v_R, v_t, v_cam_twist);
}

}  // namespace

void ProjectBackward(const GaussianParams& params, const CameraData& cam, const uint8_t* status,
                     const uint8_t* clamped, const float* screen_grads, const GaussianGrads& grads) {
  const int n = params.num_gaussians;
  DeviceArray<double> pose_sums;
  if (grads.v_cam_twist != nullptr) {
    pose_sums.Resize(kPoseParts);
    pose_sums.Zero();
  }
  if (n > 0) {
    ProjectBackwardKernel<<<DivUp(n, kGaussianBlock), kGaussianBlock>>>(
        n, params.means, params.log_scales, params.quats, params.opacity_logits, params.sh, params.sh_coeffs, cam,
        status, clamped, screen_grads, grads.v_means, grads.v_log_scales, grads.v_quats, grads.v_opacity_logits,
        grads.v_sh, grads.v_mean2d_abs, pose_sums.data());
    DYPHO_CUDA_CHECK_LAUNCH("ProjectBackwardKernel");
  }
  if (grads.v_cam_twist != nullptr) {
    PoseTwistKernel<<<1, 1>>>(cam, pose_sums.data(), grads.v_cam_twist);
    DYPHO_CUDA_CHECK_LAUNCH("PoseTwistKernel");
  }
}

}  // namespace dypho::kernels::cuda
