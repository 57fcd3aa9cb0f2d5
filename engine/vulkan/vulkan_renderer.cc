#include "engine/vulkan/vulkan_renderer.h"

#include "engine/vulkan/splat_renderer.h"
#include "engine/vulkan/vk_context.h"

namespace dypho::vulkan {

struct VulkanRenderer::Impl {
  explicit Impl(const ContextOptions& options) : context(options), splats(&context) {}
  Context context;
  SplatRenderer splats;
};

bool VulkanAvailable(std::string* why) {
  try {
    ContextOptions options;
    options.print_device = false;
    Context context(options);
    return true;
  } catch (const VulkanError& e) {
    if (why) *why = e.what();
    return false;
  }
}

VulkanRenderer::VulkanRenderer(const VulkanRendererOptions& options) {
  ContextOptions c;
  c.validation = options.validation;  // or DYPHO_VULKAN_VALIDATION=1 (Context)
  c.print_device = options.print_device;
  impl_ = std::make_unique<Impl>(c);
}

VulkanRenderer::~VulkanRenderer() = default;

std::string VulkanRenderer::device_description() const { return impl_->context.device_description(); }
int VulkanRenderer::validation_messages() const { return impl_->context.validation_messages(); }
bool VulkanRenderer::validation_enabled() const { return impl_->context.validation_enabled(); }
void VulkanRenderer::SetMap(const GaussianCloud& cloud) { impl_->splats.SetMap(cloud); }
int VulkanRenderer::num_gaussians() const { return impl_->splats.num_gaussians(); }

RenderedView VulkanRenderer::Render(const kernels::RasterCamera& camera, const kernels::RasterSettings& settings) {
  impl_->splats.Validate(camera, settings);
  VkCommandBuffer cmd = impl_->context.BeginOneShot();
  try {
    impl_->splats.Record(cmd, camera, settings, SplatDrawOptions{}, nullptr);
  } catch (...) {
    vkEndCommandBuffer(cmd);
    vkFreeCommandBuffers(impl_->context.device(), impl_->context.command_pool(), 1, &cmd);
    throw;
  }
  impl_->context.SubmitAndWait(cmd);
  RenderedView view;
  view.color = ImageF(camera.width, camera.height, 3);
  view.depth = ImageF(camera.width, camera.height, 1);
  view.alpha = ImageF(camera.width, camera.height, 1);
  impl_->splats.ReadOutputs(view.color.data(), view.depth.data(), view.alpha.data(), &view.stats);
  return view;
}

VulkanRenderer::StageTimes VulkanRenderer::last_stage_times() const {
  const vulkan::StageTimes t = impl_->splats.ReadStageTimes();
  return {t.project, t.sort, t.draw, t.resolve};
}

RenderedView VulkanRenderer::Render(const Camera& camera, const Rigid3d& cam_from_world,
                                    const kernels::RasterSettings& settings) {
  return Render(ToRasterCamera(camera, cam_from_world), settings);
}

}  // namespace dypho::vulkan
