// The Gaussian splatting pipeline on a Vulkan device, recorded into a
// command buffer: projection (compute), radix sort of depth keys (compute,
// sorted mode), instanced quads with per-fragment conic evaluation and
// hardware blending into float32 targets, and a resolve pass. Internal to
// engine/vulkan; the offscreen renderer and the viewer record it.
#pragma once

#include <array>
#include <cstdint>

#include "engine/gaussians.h"
#include "engine/vulkan/vk_context.h"
#include "kernels/rasterizer.h"

namespace dypho::vulkan {

struct SplatDrawOptions {
  bool points = false;        // draw each Gaussian as a disc instead of its ellipse
  float point_radius = 1.5f;  // disc radius [px]
};

// Device time of the stages of the last render [ms], from timestamp
// queries (all zero when the device has no timestamps).
struct StageTimes {
  double project = 0, sort = 0, draw = 0, resolve = 0;
};

class SplatRenderer {
 public:
  explicit SplatRenderer(Context* context);
  ~SplatRenderer();
  SplatRenderer(const SplatRenderer&) = delete;
  SplatRenderer& operator=(const SplatRenderer&) = delete;

  // Uploads the map (validated: array sizes; non-finite entries are culled
  // when drawn, as by the CPU rasterizer).
  void SetMap(const GaussianCloud& cloud);
  int num_gaussians() const { return n_; }

  // Checks the camera and settings (InvalidInput naming the field),
  // including the device's image size limits.
  void Validate(const kernels::RasterCamera& camera, const kernels::RasterSettings& settings) const;

  // Records one render. `display` (may be null): an RGBA8 storage image of
  // the camera's size, left in VK_IMAGE_LAYOUT_GENERAL with the clamped
  // colour. The float outputs land in a host-visible buffer read by
  // ReadOutputs after the command buffer completed.
  void Record(VkCommandBuffer cmd, const kernels::RasterCamera& camera, const kernels::RasterSettings& settings,
              const SplatDrawOptions& draw, const Image* display);

  // After completion of the last Record: colour [H, W, 3], depth [H, W],
  // alpha [H, W] as in kernels::RasterOutputs (null pointers skipped) and
  // the visible / non-finite counts.
  void ReadOutputs(float* color, float* depth, float* alpha, kernels::RasterStats* stats) const;
  // After completion of the last Record.
  StageTimes ReadStageTimes() const;

 private:
  void Release();
  void CreatePipelines();
  void EnsureTargets(uint32_t width, uint32_t height);
  void EnsureDisplayBinding(const Image* display);
  void DestroyMap();
  void DestroyTargets();
  void WriteDescriptors();

  Context* ctx_;
  // Map and per-Gaussian buffers.
  int n_ = 0;
  int sh_coeffs_ = 1;
  Buffer means_, log_scales_, quats_, logits_, sh_;
  Buffer splats_, keys_[2], values_[2], hist_buf_;
  Buffer indices_;  // quad index buffer (empty: unindexed draw)
  uint32_t sort_items_ = 1, sort_threads_ = 1;
  Buffer camera_ubo_, stats_;
  // Targets.
  uint32_t width_ = 0, height_ = 0;
  Image acc0_, acc1_, dummy_display_;
  Buffer out_;
  VkFramebuffer framebuffer_ = VK_NULL_HANDLE;
  VkImageView bound_display_ = VK_NULL_HANDLE;
  bool outputs_valid_ = false;
  uint32_t last_width_ = 0, last_height_ = 0;

  // Pipelines.
  VkDescriptorSetLayout project_layout_ = VK_NULL_HANDLE, hist_layout_ = VK_NULL_HANDLE, scan_layout_ = VK_NULL_HANDLE,
                        scatter_layout_ = VK_NULL_HANDLE, draw_layout_ = VK_NULL_HANDLE,
                        resolve_layout_ = VK_NULL_HANDLE, args_layout_ = VK_NULL_HANDLE;
  VkPipelineLayout project_pl_ = VK_NULL_HANDLE, hist_pl_ = VK_NULL_HANDLE, scan_pl_ = VK_NULL_HANDLE,
                   scatter_pl_ = VK_NULL_HANDLE, draw_pl_ = VK_NULL_HANDLE, resolve_pl_ = VK_NULL_HANDLE,
                   args_pl_ = VK_NULL_HANDLE;
  VkPipeline project_ = VK_NULL_HANDLE, hist_ = VK_NULL_HANDLE, scan_ = VK_NULL_HANDLE, scatter_ = VK_NULL_HANDLE,
             draw_sorted_ = VK_NULL_HANDLE, draw_oit_ = VK_NULL_HANDLE, resolve_ = VK_NULL_HANDLE,
             args_ = VK_NULL_HANDLE;
  VkRenderPass render_pass_ = VK_NULL_HANDLE;
  VkQueryPool timestamps_ = VK_NULL_HANDLE;  // 5 stamps per render; null without timestamp support
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet project_set_ = VK_NULL_HANDLE, scan_set_ = VK_NULL_HANDLE, resolve_set_ = VK_NULL_HANDLE,
                  args_set_ = VK_NULL_HANDLE;
  // [k]: reads the sort result in values_[k] (4 passes end in 0, 1 pass in 1).
  std::array<VkDescriptorSet, 2> hist_sets_{}, scatter_sets_{}, draw_sets_{};
  Buffer draw_args_;  // indirect draw arguments (draw_args.comp)
};

}  // namespace dypho::vulkan
