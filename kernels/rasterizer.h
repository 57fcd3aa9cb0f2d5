// Differentiable 3D Gaussian rasterization: the backend interface.
//
// One interface, several backends (CPU reference, CUDA). All pointers live in
// the backend's memory space (host memory for the CPU backend, device memory
// for the CUDA backend). Shapes are given in comments; every array is dense,
// row-major and float32 unless said otherwise.
//
// Conventions
// - Camera: pinhole, x right, y down, z forward; `cam_from_world` maps world
//   points to camera points. Pixel (u, v) has its centre at (u, v), as in
//   OpenCV and the TUM calibration.
// - Gaussian i: mean [3], log-scale [3], rotation quaternion (w, x, y, z)
//   normalised inside, opacity = sigmoid(logit), colour from real spherical
//   harmonics of degree 0..3 (`sh_coeffs` = 1, 4, 9 or 16 per channel),
//   evaluated for the direction from the camera centre to the mean, plus 0.5,
//   clamped at 0 (as in Kerbl et al. 2023, "3D Gaussian Splatting").
// - A Gaussian contributes to pixel p iff its camera depth is inside
//   [near_plane, far_plane], its 2D mean is within the extended frustum, and
//   at p: sigma^2 = d^T conic d <= 9 (inside the 3-sigma ellipse) and
//   power = -sigma^2 / 2 >= -log(255 * opacity) (alpha >= 1/255).
//   alpha = min(0.99, opacity * exp(power)). The 3-sigma ellipse test makes
//   the result independent of the tiling (vanilla 3DGS truncates at tile
//   bounding boxes instead); tiles only accelerate.
// - Sorted mode: front-to-back over Gaussians in increasing camera depth
//   (ties by index): w_i = alpha_i T_i, T_{i+1} = T_i (1 - alpha_i); a
//   Gaussian that would bring T below 1e-4 is not composited and ends the
//   pixel. colour = sum w_i c_i + T_final * background; depth = sum w_i z_i;
//   alpha = 1 - T_final.
// - Order-independent mode: weighted blended OIT (McGuire & Bavoil 2013,
//   "Weighted Blended Order-Independent Transparency", JCGT 2(2), eq. 7):
//   f(z) = clamp(10 / (1e-5 + (z/5)^2 + (z/200)^6), 1e-2, 3e3),
//   A = sum alpha_i f_i, P = prod (1 - alpha_i),
//   colour = (sum alpha_i f_i c_i / A) (1 - P) + P * background,
//   depth = (sum alpha_i f_i z_i / A) (1 - P), alpha = 1 - P.
//   Every contributing Gaussian is summed; no sort, no early termination.
//   With one Gaussian per pixel both modes agree exactly.
// - Non-finite parameters (NaN, +-inf: e.g. a zero scale given as log 0) and
//   opacities below 1/255 cull the Gaussian: it renders nothing, its radius
//   is 0 and its gradients are 0. The counts are reported in RasterStats.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

namespace dypho::kernels {

enum class Backend { kCpu, kCuda };
enum class CompositeMode { kSorted, kOrderIndependent };

const char* BackendName(Backend backend);
const char* CompositeModeName(CompositeMode mode);

constexpr int kTileSize = 16;        // tiles are kTileSize x kTileSize pixels
constexpr int kMaxShCoeffs = 16;     // degree 3

// The parameter, output and gradient structs are templated on the scalar so
// the CPU reference can also run in double precision (finite-difference
// tests); backends take the float instantiations.
template <typename T>
struct GaussianParamsT {
  const T* means = nullptr;           // [N, 3] world coordinates
  const T* log_scales = nullptr;      // [N, 3] log of the standard deviations
  const T* quats = nullptr;           // [N, 4] w, x, y, z (normalised inside)
  const T* opacity_logits = nullptr;  // [N]
  const T* sh = nullptr;              // [N, sh_coeffs, 3]
  int num_gaussians = 0;              // N
  int sh_coeffs = 1;                  // 1, 4, 9 or 16
};
using GaussianParams = GaussianParamsT<float>;

struct RasterCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pinhole intrinsics [px]
  int width = 0, height = 0;              // image size [px]
  double cam_from_world[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // row-major 3x4 [R | t]
};

struct RasterSettings {
  CompositeMode mode = CompositeMode::kSorted;  // compositing
  int sh_degree = 3;                  // active SH degree, clipped to what sh_coeffs holds
  float background[3] = {0, 0, 0};    // colour where nothing covers a pixel
  float near_plane = 0.01f;           // nearest camera depth rendered [m]
  float far_plane = 1.0e4f;           // farthest camera depth rendered [m]
  float low_pass = 0.3f;              // EWA dilation added to the 2D covariance [px^2]
  int num_threads = 0;                // CPU backend threads; 0 = all hardware threads

  // False (with the field and the violated constraint in `error`) when invalid.
  bool IsValid(std::string* error) const;
};

template <typename T>
struct RasterOutputsT {
  T* color = nullptr;        // [H, W, 3]
  T* depth = nullptr;        // [H, W] expected camera z (not normalised by alpha)
  T* alpha = nullptr;        // [H, W] accumulated opacity
  int32_t* radii = nullptr;  // [N] 3-sigma radius in pixels; 0 = not visible (may be null)
};
using RasterOutputs = RasterOutputsT<float>;

// Cotangents of a scalar loss with respect to the outputs; a null pointer
// means zero.
template <typename T>
struct RasterOutputGradsT {
  const T* v_color = nullptr;  // [H, W, 3]
  const T* v_depth = nullptr;  // [H, W]
  const T* v_alpha = nullptr;  // [H, W]
};
using RasterOutputGrads = RasterOutputGradsT<float>;

// Gradients written (overwritten, not accumulated) by Backward. Any pointer
// may be null to skip that output.
template <typename T>
struct GaussianGradsT {
  T* v_means = nullptr;           // [N, 3]
  T* v_log_scales = nullptr;      // [N, 3]
  T* v_quats = nullptr;           // [N, 4]
  T* v_opacity_logits = nullptr;  // [N]
  T* v_sh = nullptr;              // [N, sh_coeffs, 3]
  // Gradient with respect to a twist xi = (rho, phi) that perturbs the camera
  // on the left: cam_from_world' = exp(xi) * cam_from_world. [6]
  T* v_cam_twist = nullptr;
  // Per Gaussian, the norm of dL/d mean2d, the gradient with respect to the
  // 2D mean (its per-pixel contributions summed first, then the norm taken, as
  // in vanilla 3DGS; not AbsGS's sum of absolute values) [loss units per
  // pixel; 3DGS's NDC threshold 0.0002 corresponds to about 0.0002 * 2 / W]:
  // the screen-space positional gradient that densification needs. [N]
  T* v_mean2d_abs = nullptr;
};
using GaussianGrads = GaussianGradsT<float>;

struct RasterStats {
  int num_gaussians = 0;
  int num_visible = 0;       // radius > 0
  int num_nonfinite = 0;     // culled for NaN / inf parameters
  int64_t num_tile_pairs = 0;  // (Gaussian, tile) pairs
  // Gaussian-pixel evaluations in the forward pass (pixels of a Gaussian's
  // footprint tested before their pixel terminated); 0 when not counted.
  int64_t num_evaluations = 0;
};

// What Forward keeps for Backward. Backend-specific; opaque to callers.
class RasterState {
 public:
  virtual ~RasterState() = default;
  virtual RasterStats stats() const = 0;
};

class Rasterizer {
 public:
  virtual ~Rasterizer() = default;
  virtual Backend backend() const = 0;

  // Renders `params` seen by `camera`. Throws InvalidInput on a bad camera,
  // settings or shapes (naming the field). N = 0 renders the background.
  virtual std::unique_ptr<RasterState> Forward(const GaussianParams& params,
                                               const RasterCamera& camera,
                                               const RasterSettings& settings,
                                               const RasterOutputs& outputs) = 0;

  // Gradients for the state of a Forward with the same params, camera and
  // settings.
  virtual void Backward(const RasterState& state, const GaussianParams& params,
                        const RasterCamera& camera, const RasterSettings& settings,
                        const RasterOutputGrads& output_grads, const GaussianGrads& grads) = 0;
};

// True when `backend` is compiled in and usable here; otherwise `why` says
// why (for CUDA: how to rebuild, or that no device is present).
bool BackendAvailable(Backend backend, std::string* why);

// The one place that knows about build flags. Throws InvalidInput with a
// message saying how to rebuild when the backend is missing.
std::unique_ptr<Rasterizer> CreateRasterizer(Backend backend);

// Checks the camera, the settings and the parameter shape; throws
// InvalidInput naming the offending field. Shared by all backends.
// `have_pointers`: every parameter array is non-null (or N = 0).
void ValidateRasterInputs(int num_gaussians, int sh_coeffs, bool have_pointers, const RasterCamera& camera,
                          const RasterSettings& settings);
template <typename T>
void ValidateRasterInputs(const GaussianParamsT<T>& params, const RasterCamera& camera,
                          const RasterSettings& settings) {
  const bool have = params.num_gaussians == 0 || (params.means && params.log_scales && params.quats &&
                                                  params.opacity_logits && params.sh);
  ValidateRasterInputs(params.num_gaussians, params.sh_coeffs, have, camera, settings);
}

}  // namespace dypho::kernels
