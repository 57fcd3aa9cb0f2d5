// Vulkan instance, device and memory helpers shared by the offscreen
// renderer and the viewer. Internal to engine/vulkan (the public API is
// vulkan_renderer.h and viewer.h).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

namespace dypho::vulkan {

// A Vulkan call failed at run time (out of memory, device lost, missing
// driver). The message names the call and the VkResult.
class VulkanError : public std::runtime_error {
 public:
  explicit VulkanError(const std::string& what) : std::runtime_error(what) {}
};

const char* ResultName(VkResult result);
[[noreturn]] void ThrowVulkanError(const char* call, VkResult result, const char* file, int line);

#define DYPHO_VK(call)                                                                \
  do {                                                                                \
    const VkResult dypho_vk_result_ = (call);                                         \
    if (dypho_vk_result_ != VK_SUCCESS)                                               \
      ::dypho::vulkan::ThrowVulkanError(#call, dypho_vk_result_, __FILE__, __LINE__); \
  } while (0)

struct ContextOptions {
  // Enable VK_LAYER_KHRONOS_validation when installed (also switched on by
  // the environment variable DYPHO_VULKAN_VALIDATION=1).
  bool validation = false;
  std::vector<std::string> instance_extensions;  // e.g. the window system's surface extensions
  bool swapchain = false;                        // require VK_KHR_swapchain on the device
  bool print_device = true;                      // print the chosen device to stderr
};

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* mapped = nullptr;  // host-visible buffers stay mapped
};

struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkFormat format = VK_FORMAT_UNDEFINED;
  uint32_t width = 0, height = 0;
};

// Owns instance, device, one graphics+compute queue and a command pool.
class Context {
 public:
  explicit Context(const ContextOptions& options);
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physical_device() const { return physical_; }
  VkDevice device() const { return device_; }
  VkQueue queue() const { return queue_; }
  uint32_t queue_family() const { return queue_family_; }
  VkCommandPool command_pool() const { return pool_; }
  const VkPhysicalDeviceProperties& properties() const { return properties_; }
  std::string device_description() const;  // "name (type, driver)"
  bool validation_enabled() const { return validation_enabled_; }
  // Validation-layer messages of severity warning or error so far.
  int validation_messages() const { return validation_messages_; }

  Buffer CreateBuffer(VkDeviceSize size, VkBufferUsageFlags usage, bool host_visible);
  void Destroy(Buffer* buffer);
  Image CreateImage(uint32_t width, uint32_t height, VkFormat format, VkImageUsageFlags usage);
  void Destroy(Image* image);
  VkShaderModule CreateShader(const std::string& name);  // an embedded shader (shaders/embedded.h)

  VkCommandBuffer BeginOneShot();
  void SubmitAndWait(VkCommandBuffer cmd);  // ends, submits, waits, frees

  // Called by the debug messenger.
  void OnValidationMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity, const char* message);

 private:
  void Release();
  uint32_t FindMemoryType(uint32_t type_bits, VkMemoryPropertyFlags wanted, VkMemoryPropertyFlags preferred);

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queue_family_ = 0;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkPhysicalDeviceProperties properties_{};
  VkPhysicalDeviceMemoryProperties memory_{};
  bool validation_enabled_ = false;
  int validation_messages_ = 0;
};

// Image layout transition with a full pipeline barrier for the given stages.
void TransitionImage(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                     VkAccessFlags dst_access, VkPipelineStageFlags src_stage, VkPipelineStageFlags dst_stage);
// Memory barrier between two pipeline stages.
void StageBarrier(VkCommandBuffer cmd, VkAccessFlags src_access, VkAccessFlags dst_access,
                  VkPipelineStageFlags src_stage, VkPipelineStageFlags dst_stage);

// A pipeline stage with the accesses it makes (one side of a dependency).
struct StageAccess {
  VkPipelineStageFlags stage = 0;
  VkAccessFlags access = 0;
};

// A render pass of one subpass over colour attachments of `formats`, each
// loaded with `load` from layout `initial` and stored in `final_layout`; two
// external dependencies order the subpass after `before` and ahead of
// `after` (the colour-attachment side is filled in).
VkRenderPass CreateColorRenderPass(VkDevice device, const std::vector<VkFormat>& formats, VkAttachmentLoadOp load,
                                   VkImageLayout initial, VkImageLayout final_layout, StageAccess before,
                                   StageAccess after);

// A graphics pipeline with a vertex and a fragment shader (embedded names),
// no culling, one sample, dynamic viewport and scissor.
struct GraphicsPipelineDesc {
  const char* vertex_shader = nullptr;
  const char* fragment_shader = nullptr;
  VkPrimitiveTopology topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  std::vector<VkVertexInputBindingDescription> bindings;      // none: vertices come from the shader
  std::vector<VkVertexInputAttributeDescription> attributes;
  std::vector<VkPipelineColorBlendAttachmentState> blend;     // one per colour attachment
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkRenderPass render_pass = VK_NULL_HANDLE;
};
VkPipeline CreateGraphicsPipeline(Context* context, const GraphicsPipelineDesc& desc);

}  // namespace dypho::vulkan
