// Offscreen rendering of a Gaussian map with Vulkan: the same images as the
// CPU reference rasterizer (kernels/rasterizer.h) for both compositing modes,
// computed on whatever Vulkan device is present (a discrete GPU first, then
// any GPU, then Mesa's lavapipe CPU driver; the choice is printed).
//
// Pipeline (shaders/): projection and SH colour in a compute shader; in
// sorted mode a stable LSD radix sort of the depth keys (4 passes of 8 bits,
// compute), so ties keep index order as on the CPU; in OIT mode one stable
// pass that moves the visible Gaussians first in index order; an indirect
// draw of the visible ones only: one indexed quad per Gaussian over the
// bounding box of its cut-off ellipse, the conic evaluated
// per fragment (3 sigma, alpha >= 1/255, alpha = min(0.99, o exp(power))
// with the CPU's exp polynomial); hardware blending into R32G32B32A32_SFLOAT
// targets; a resolve compute pass.
//   sorted: front to back, T in the alpha channel (cleared to 1):
//           rgb += T (alpha c), T *= 1 - alpha.
//   OIT:    one additive pass (sums of alpha f c, alpha f, alpha f z; product
//           of 1 - alpha) and the resolve of kernels/rasterizer.h.
// Differences from the CPU reference (measured in tests/vulkan_parity_test.cc):
//   - sorted mode has no early stop at T < 1e-4: the CPU drops the Gaussian
//     that would bring T below 1e-4 and everything behind it (remaining
//     weight < 1e-2 by alpha <= 0.99, usually far less); hardware blending
//     composites them all, so alpha can be slightly larger and colour/depth
//     differ by at most that remaining weight;
//   - projection uses the device's exp/log/sqrt and may contract
//     multiply-adds, so the conic differs in the last bits; pixels at the
//     exact cut-off boundary can flip.
// Measured on lavapipe (tests/vulkan_parity_test.cc, BENCHMARKS.md): colour
// PSNR 84 to 115 dB (sorted) and 108 to 141 dB (OIT) against the CPU;
// normalised depth within 0.3% (sorted) and 6e-5 (OIT); largest alpha
// difference 0.009 (sorted, a map from a real TUM frame, where many pixels
// reach the early stop) and 0.009 in OIT (one pixel at a 3-sigma boundary).
// Non-finite Gaussians are culled as on the CPU (counted in RasterStats);
// an empty map renders the background.
#pragma once

#include <memory>
#include <string>

#include "common/camera.h"
#include "common/rigid3.h"
#include "engine/gaussians.h"
#include "engine/render/render.h"
#include "kernels/rasterizer.h"

namespace dypho::vulkan {

struct VulkanRendererOptions {
  // Enable the Khronos validation layer when installed (a note is printed
  // when it is not). Also switched on by the environment variable
  // DYPHO_VULKAN_VALIDATION=1.
  bool validation = false;
  bool print_device = true;  // print the chosen device to stderr
};

// True when a Vulkan driver and a usable device exist; otherwise `why` says
// which package to install.
bool VulkanAvailable(std::string* why);

class VulkanRenderer {
 public:
  // Throws VulkanError (engine/vulkan/vk_context.h) with the package to
  // install when there is no driver or no suitable device.
  explicit VulkanRenderer(const VulkanRendererOptions& options = {});
  ~VulkanRenderer();
  VulkanRenderer(const VulkanRenderer&) = delete;
  VulkanRenderer& operator=(const VulkanRenderer&) = delete;

  std::string device_description() const;
  // Validation-layer warnings and errors reported so far (0 without the layer).
  int validation_messages() const;
  bool validation_enabled() const;

  // Uploads the map once; later renders reuse it.
  void SetMap(const GaussianCloud& cloud);
  int num_gaussians() const;

  // Renders the current map. Throws InvalidInput for a bad camera or
  // settings (naming the field) or an image beyond the device's limits.
  RenderedView Render(const kernels::RasterCamera& camera, const kernels::RasterSettings& settings);
  RenderedView Render(const Camera& camera, const Rigid3d& cam_from_world, const kernels::RasterSettings& settings);

  // Device time of the last Render's stages [ms]: projection, sort (0 in
  // OIT mode), splat drawing, resolve + readback barrier. Zero when the
  // device has no timestamps.
  struct StageTimes {
    double project = 0, sort = 0, draw = 0, resolve = 0;
  };
  StageTimes last_stage_times() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho::vulkan
