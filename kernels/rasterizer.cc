#include "kernels/rasterizer.h"

#include <cmath>
#include <sstream>

#include "common/check.h"
#include "common/files.h"
#include "kernels/cpu/cpu_rasterizer.h"
#if defined(DYPHO_WITH_CUDA)
#include "kernels/cuda/cuda_rasterizer.h"
#endif

namespace dypho::kernels {

const char* BackendName(Backend backend) { return backend == Backend::kCpu ? "cpu" : "cuda"; }

const char* CompositeModeName(CompositeMode mode) {
  return mode == CompositeMode::kSorted ? "sorted" : "order-independent";
}

bool RasterSettings::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (sh_degree < 0 || sh_degree > 3) msg << "sh_degree must be in [0, 3] (got " << sh_degree << ")";
  else if (!(std::isfinite(near_plane) && near_plane > 0)) msg << "near_plane must be > 0 (got " << near_plane << ")";
  else if (!(far_plane > near_plane)) msg << "far_plane must be > near_plane (got " << far_plane << ")";
  else if (!(std::isfinite(low_pass) && low_pass >= 0)) msg << "low_pass must be >= 0 (got " << low_pass << ")";
  else if (num_threads < 0 || num_threads > kMaxThreads)
    msg << "num_threads must be in [0, " << kMaxThreads << "] (got " << num_threads << ")";
  else {
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(background[c])) {
        msg << "background[" << c << "] must be finite";
        break;
      }
    }
  }
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

void ValidateRasterInputs(int num_gaussians, int sh_coeffs, bool have_pointers, const RasterCamera& camera,
                          const RasterSettings& settings) {
  std::string error;
  DYPHO_CHECK_INPUT(settings.IsValid(&error)) << "raster settings: " << error;
  DYPHO_CHECK_INPUT(camera.width > 0 && camera.height > 0)
      << "raster camera: image size must be positive (got " << camera.width << "x" << camera.height << ")";
  DYPHO_CHECK_INPUT(camera.width <= 32768 && camera.height <= 32768)
      << "raster camera: image size " << camera.width << "x" << camera.height << " exceeds 32768";
  DYPHO_CHECK_INPUT(std::isfinite(camera.fx) && camera.fx > 0 && std::isfinite(camera.fy) && camera.fy > 0)
      << "raster camera: fx and fy must be finite and > 0 (got " << camera.fx << ", " << camera.fy << ")";
  DYPHO_CHECK_INPUT(std::isfinite(camera.cx) && std::isfinite(camera.cy))
      << "raster camera: cx and cy must be finite";
  for (int i = 0; i < 12; ++i) {
    DYPHO_CHECK_INPUT(std::isfinite(camera.cam_from_world[i]))
        << "raster camera: cam_from_world[" << i << "] is not finite";
  }
  DYPHO_CHECK_INPUT(num_gaussians >= 0) << "Gaussians: count must be >= 0 (got " << num_gaussians << ")";
  DYPHO_CHECK_INPUT(sh_coeffs == 1 || sh_coeffs == 4 || sh_coeffs == 9 || sh_coeffs == 16)
      << "Gaussians: sh_coeffs must be 1, 4, 9 or 16 (got " << sh_coeffs << ")";
  DYPHO_CHECK_INPUT(have_pointers) << "Gaussians: a parameter array is null";
}

bool BackendAvailable(Backend backend, std::string* why) {
  if (backend == Backend::kCpu) return true;
#if defined(DYPHO_WITH_CUDA)
  return cuda::CudaDeviceAvailable(why);
#else
  if (why) {
    *why = "this build of dypho has no CUDA backend: install the CUDA toolkit (nvcc) and reconfigure "
           "with -DDYPHO_WITH_CUDA=ON";
  }
  return false;
#endif
}

std::unique_ptr<Rasterizer> CreateRasterizer(Backend backend) {
  if (backend == Backend::kCpu) return cpu::CreateCpuRasterizer();
  std::string why;
  DYPHO_CHECK_INPUT(BackendAvailable(backend, &why)) << "CUDA rasterizer unavailable: " << why;
#if defined(DYPHO_WITH_CUDA)
  return cuda::CreateCudaRasterizer();
#else
  return nullptr;
#endif
}

}  // namespace dypho::kernels
