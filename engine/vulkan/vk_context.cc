#include "engine/vulkan/vk_context.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include "shaders/embedded.h"

namespace dypho::vulkan {

const char* ResultName(VkResult result) {
  switch (result) {
#define DYPHO_CASE(x) \
  case x:             \
    return #x;
    DYPHO_CASE(VK_SUCCESS)
    DYPHO_CASE(VK_NOT_READY)
    DYPHO_CASE(VK_TIMEOUT)
    DYPHO_CASE(VK_INCOMPLETE)
    DYPHO_CASE(VK_SUBOPTIMAL_KHR)
    DYPHO_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    DYPHO_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    DYPHO_CASE(VK_ERROR_INITIALIZATION_FAILED)
    DYPHO_CASE(VK_ERROR_DEVICE_LOST)
    DYPHO_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    DYPHO_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    DYPHO_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    DYPHO_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    DYPHO_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    DYPHO_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    DYPHO_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    DYPHO_CASE(VK_ERROR_SURFACE_LOST_KHR)
    DYPHO_CASE(VK_ERROR_OUT_OF_DATE_KHR)
    DYPHO_CASE(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR)
#undef DYPHO_CASE
    default:
      return "VkResult(unknown)";
  }
}

void ThrowVulkanError(const char* call, VkResult result, const char* file, int line) {
  std::ostringstream s;
  s << "Vulkan call failed: " << call << " returned " << ResultName(result) << " (" << file << ":" << line << ")";
  throw VulkanError(s.str());
}

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
constexpr const char* kNoDriverHelp =
    "install a Vulkan driver: on Debian/Ubuntu `sudo apt-get install mesa-vulkan-drivers` "
    "(provides lavapipe, a CPU Vulkan driver, and the Mesa GPU drivers) or your GPU vendor's driver; "
    "the CPU renderer (--backend cpu) needs none";

VKAPI_ATTR VkBool32 VKAPI_CALL DebugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                             VkDebugUtilsMessageTypeFlagsEXT,
                                             const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  static_cast<Context*>(user)->OnValidationMessage(severity, data->pMessage);
  return VK_FALSE;
}

bool HasLayer(const char* name) {
  uint32_t count = 0;
  vkEnumerateInstanceLayerProperties(&count, nullptr);
  std::vector<VkLayerProperties> layers(count);
  vkEnumerateInstanceLayerProperties(&count, layers.data());
  for (const auto& l : layers) {
    if (std::strcmp(l.layerName, name) == 0) return true;
  }
  return false;
}

// Discrete GPU first, then any other GPU, then CPU drivers (lavapipe).
int DeviceRank(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 4;
    default:
      return 3;
  }
}

const char* DeviceTypeName(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return "CPU";
    default:
      return "other";
  }
}

bool DeviceHasExtension(VkPhysicalDevice device, const char* name) {
  uint32_t count = 0;
  vkEnumerateDeviceExtensionProperties(device, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> ext(count);
  vkEnumerateDeviceExtensionProperties(device, nullptr, &count, ext.data());
  for (const auto& e : ext) {
    if (std::strcmp(e.extensionName, name) == 0) return true;
  }
  return false;
}

// The renderer blends into float32 colour attachments and stores to them.
bool DeviceSupportsFormats(VkPhysicalDevice device) {
  VkFormatProperties p;
  vkGetPhysicalDeviceFormatProperties(device, VK_FORMAT_R32G32B32A32_SFLOAT, &p);
  const VkFormatFeatureFlags need = VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT |
                                    VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BLEND_BIT | VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT;
  if ((p.optimalTilingFeatures & need) != need) return false;
  vkGetPhysicalDeviceFormatProperties(device, VK_FORMAT_R8G8B8A8_UNORM, &p);
  const VkFormatFeatureFlags need8 = VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT | VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT;
  return (p.optimalTilingFeatures & need8) == need8;
}

// The order-independent mode blends its two targets differently.
bool HasIndependentBlend(VkPhysicalDevice device) {
  VkPhysicalDeviceFeatures f;
  vkGetPhysicalDeviceFeatures(device, &f);
  return f.independentBlend == VK_TRUE;
}

}  // namespace

Context::Context(const ContextOptions& options) {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "dypho";
  app.pEngineName = "dypho";
  app.apiVersion = VK_API_VERSION_1_1;

  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  for (const auto& e : options.instance_extensions) extensions.push_back(e.c_str());
  const char* env = std::getenv("DYPHO_VULKAN_VALIDATION");
  const bool env_validation = env != nullptr && std::string(env) != "" && std::string(env) != "0";
  if (options.validation || env_validation) {
    if (HasLayer(kValidationLayer)) {
      layers.push_back(kValidationLayer);
      extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
      validation_enabled_ = true;
    } else {
      std::fprintf(stderr,
                   "dypho: Vulkan validation requested but %s is not installed "
                   "(Debian: apt-get install vulkan-validationlayers); running without it\n",
                   kValidationLayer);
    }
  }
  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &app;
  ici.enabledLayerCount = static_cast<uint32_t>(layers.size());
  ici.ppEnabledLayerNames = layers.data();
  ici.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  ici.ppEnabledExtensionNames = extensions.data();
  VkDebugUtilsMessengerCreateInfoEXT dci{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  dci.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  dci.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  dci.pfnUserCallback = DebugCallback;
  dci.pUserData = this;
  if (validation_enabled_) ici.pNext = &dci;  // also reports vkCreateInstance itself
  const VkResult r = vkCreateInstance(&ici, nullptr, &instance_);
  if (r == VK_ERROR_INCOMPATIBLE_DRIVER || r == VK_ERROR_INITIALIZATION_FAILED) {
    throw VulkanError(std::string("no Vulkan driver found (vkCreateInstance: ") + ResultName(r) +
                      "): " + kNoDriverHelp);
  }
  if (r == VK_ERROR_EXTENSION_NOT_PRESENT) {
    throw VulkanError("the Vulkan driver lacks a required instance extension (window-system surface support?)");
  }
  DYPHO_VK(r);
  try {
    if (validation_enabled_) {
      auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
      if (create) DYPHO_VK(create(instance_, &dci, nullptr, &messenger_));
    }

    uint32_t count = 0;
    DYPHO_VK(vkEnumeratePhysicalDevices(instance_, &count, nullptr));
    std::vector<VkPhysicalDevice> devices(count);
    if (count > 0) DYPHO_VK(vkEnumeratePhysicalDevices(instance_, &count, devices.data()));
    if (devices.empty()) throw VulkanError(std::string("no Vulkan device found: ") + kNoDriverHelp);

    // Usable: a queue family with graphics and compute, the formats, and the
    // swapchain extension when a window is wanted.
    int best_rank = 1 << 30;
    std::string rejected;
    for (VkPhysicalDevice d : devices) {
      VkPhysicalDeviceProperties p;
      vkGetPhysicalDeviceProperties(d, &p);
      uint32_t nq = 0;
      vkGetPhysicalDeviceQueueFamilyProperties(d, &nq, nullptr);
      std::vector<VkQueueFamilyProperties> families(nq);
      vkGetPhysicalDeviceQueueFamilyProperties(d, &nq, families.data());
      int family = -1;
      for (uint32_t q = 0; q < nq; ++q) {
        const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
        if ((families[q].queueFlags & need) == need) {
          family = static_cast<int>(q);
          break;
        }
      }
      std::string why;
      if (family < 0)
        why = "no graphics+compute queue";
      else if (!DeviceSupportsFormats(d))
        why = "no blending/storage on R32G32B32A32_SFLOAT";
      else if (!HasIndependentBlend(d))
        why = "no independentBlend";
      else if (options.swapchain && !DeviceHasExtension(d, VK_KHR_SWAPCHAIN_EXTENSION_NAME))
        why = "no swapchain";
      if (!why.empty()) {
        rejected += std::string(" ") + p.deviceName + " (" + why + ");";
        continue;
      }
      const int rank = DeviceRank(p.deviceType);
      if (rank < best_rank) {
        best_rank = rank;
        physical_ = d;
        queue_family_ = static_cast<uint32_t>(family);
        properties_ = p;
      }
    }
    if (physical_ == VK_NULL_HANDLE) throw VulkanError("no suitable Vulkan device:" + rejected + " " + kNoDriverHelp);
    vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);
    if (options.print_device) std::fprintf(stderr, "dypho: Vulkan device: %s\n", device_description().c_str());

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    qci.queueFamilyIndex = queue_family_;
    qci.queueCount = 1;
    qci.pQueuePriorities = &priority;
    std::vector<const char*> device_ext;
    if (options.swapchain) device_ext.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    VkPhysicalDeviceFeatures features{};
    features.independentBlend = VK_TRUE;
    VkDeviceCreateInfo dinfo{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    dinfo.pEnabledFeatures = &features;
    dinfo.queueCreateInfoCount = 1;
    dinfo.pQueueCreateInfos = &qci;
    dinfo.enabledExtensionCount = static_cast<uint32_t>(device_ext.size());
    dinfo.ppEnabledExtensionNames = device_ext.data();
    DYPHO_VK(vkCreateDevice(physical_, &dinfo, nullptr, &device_));
    vkGetDeviceQueue(device_, queue_family_, 0, &queue_);
    VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pci.queueFamilyIndex = queue_family_;
    DYPHO_VK(vkCreateCommandPool(device_, &pci, nullptr, &pool_));
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    DYPHO_VK(vkCreateFence(device_, &fci, nullptr, &fence_));
  } catch (...) {
    Release();
    throw;
  }
}

Context::~Context() { Release(); }

void Context::Release() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    if (fence_) vkDestroyFence(device_, fence_, nullptr);
    if (pool_) vkDestroyCommandPool(device_, pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
  }
  fence_ = VK_NULL_HANDLE;
  pool_ = VK_NULL_HANDLE;
  device_ = VK_NULL_HANDLE;
  if (messenger_) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy) destroy(instance_, messenger_, nullptr);
    messenger_ = VK_NULL_HANDLE;
  }
  if (instance_) vkDestroyInstance(instance_, nullptr);
  instance_ = VK_NULL_HANDLE;
}

std::string Context::device_description() const {
  std::ostringstream s;
  s << properties_.deviceName << " (" << DeviceTypeName(properties_.deviceType) << ", Vulkan "
    << VK_API_VERSION_MAJOR(properties_.apiVersion) << "." << VK_API_VERSION_MINOR(properties_.apiVersion) << ")";
  return s.str();
}

void Context::OnValidationMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity, const char* message) {
  ++validation_messages_;
  std::fprintf(stderr, "dypho: Vulkan validation %s: %s\n",
               severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT ? "error" : "warning", message);
}

uint32_t Context::FindMemoryType(uint32_t type_bits, VkMemoryPropertyFlags wanted, VkMemoryPropertyFlags preferred) {
  for (VkMemoryPropertyFlags flags : {wanted | preferred, wanted}) {
    for (uint32_t i = 0; i < memory_.memoryTypeCount; ++i) {
      if ((type_bits & (1u << i)) && (memory_.memoryTypes[i].propertyFlags & flags) == flags) return i;
    }
  }
  throw VulkanError("no Vulkan memory type with the required properties");
}

Buffer Context::CreateBuffer(VkDeviceSize size, VkBufferUsageFlags usage, bool host_visible) {
  Buffer b;
  b.size = std::max<VkDeviceSize>(size, 16);  // zero-sized buffers are invalid
  VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = b.size;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  DYPHO_VK(vkCreateBuffer(device_, &info, nullptr, &b.buffer));
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device_, b.buffer, &req);
  VkMemoryAllocateInfo alloc{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex =
      host_visible ? FindMemoryType(req.memoryTypeBits,
                                    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                    VK_MEMORY_PROPERTY_HOST_CACHED_BIT)
                   : FindMemoryType(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  const VkResult r = vkAllocateMemory(device_, &alloc, nullptr, &b.memory);
  if (r != VK_SUCCESS) {
    vkDestroyBuffer(device_, b.buffer, nullptr);
    ThrowVulkanError("vkAllocateMemory (buffer)", r, __FILE__, __LINE__);
  }
  DYPHO_VK(vkBindBufferMemory(device_, b.buffer, b.memory, 0));
  if (host_visible) DYPHO_VK(vkMapMemory(device_, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped));
  return b;
}

void Context::Destroy(Buffer* b) {
  if (b->buffer) vkDestroyBuffer(device_, b->buffer, nullptr);
  if (b->memory) vkFreeMemory(device_, b->memory, nullptr);
  *b = Buffer{};
}

Image Context::CreateImage(uint32_t width, uint32_t height, VkFormat format, VkImageUsageFlags usage) {
  Image im;
  im.format = format;
  im.width = width;
  im.height = height;
  VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {width, height, 1};
  info.mipLevels = 1;
  info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  DYPHO_VK(vkCreateImage(device_, &info, nullptr, &im.image));
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(device_, im.image, &req);
  VkMemoryAllocateInfo alloc{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = FindMemoryType(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  DYPHO_VK(vkAllocateMemory(device_, &alloc, nullptr, &im.memory));
  DYPHO_VK(vkBindImageMemory(device_, im.image, im.memory, 0));
  VkImageViewCreateInfo vinfo{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vinfo.image = im.image;
  vinfo.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vinfo.format = format;
  vinfo.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  DYPHO_VK(vkCreateImageView(device_, &vinfo, nullptr, &im.view));
  return im;
}

void Context::Destroy(Image* im) {
  if (im->view) vkDestroyImageView(device_, im->view, nullptr);
  if (im->image) vkDestroyImage(device_, im->image, nullptr);
  if (im->memory) vkFreeMemory(device_, im->memory, nullptr);
  *im = Image{};
}

VkShaderModule Context::CreateShader(const std::string& name) {
  const shaders::Spirv spv = shaders::Get(name);
  VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = spv.size_bytes;
  info.pCode = spv.words;
  VkShaderModule module;
  DYPHO_VK(vkCreateShaderModule(device_, &info, nullptr, &module));
  return module;
}

VkCommandBuffer Context::BeginOneShot() {
  VkCommandBufferAllocateInfo info{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  info.commandPool = pool_;
  info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  info.commandBufferCount = 1;
  VkCommandBuffer cmd;
  DYPHO_VK(vkAllocateCommandBuffers(device_, &info, &cmd));
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  DYPHO_VK(vkBeginCommandBuffer(cmd, &begin));
  return cmd;
}

void Context::SubmitAndWait(VkCommandBuffer cmd) {
  DYPHO_VK(vkEndCommandBuffer(cmd));
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  DYPHO_VK(vkResetFences(device_, 1, &fence_));
  DYPHO_VK(vkQueueSubmit(queue_, 1, &submit, fence_));
  DYPHO_VK(vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX));
  vkFreeCommandBuffers(device_, pool_, 1, &cmd);
}

void TransitionImage(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                     VkAccessFlags dst_access, VkPipelineStageFlags src_stage, VkPipelineStageFlags dst_stage) {
  VkImageMemoryBarrier b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
  b.oldLayout = from;
  b.newLayout = to;
  b.srcAccessMask = src_access;
  b.dstAccessMask = dst_access;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  vkCmdPipelineBarrier(cmd, src_stage, dst_stage, 0, 0, nullptr, 0, nullptr, 1, &b);
}

void StageBarrier(VkCommandBuffer cmd, VkAccessFlags src_access, VkAccessFlags dst_access,
                  VkPipelineStageFlags src_stage, VkPipelineStageFlags dst_stage) {
  VkMemoryBarrier b{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  b.srcAccessMask = src_access;
  b.dstAccessMask = dst_access;
  vkCmdPipelineBarrier(cmd, src_stage, dst_stage, 0, 1, &b, 0, nullptr, 0, nullptr);
}

VkRenderPass CreateColorRenderPass(VkDevice device, const std::vector<VkFormat>& formats, VkAttachmentLoadOp load,
                                   VkImageLayout initial, VkImageLayout final_layout, StageAccess before,
                                   StageAccess after) {
  std::vector<VkAttachmentDescription> attachments(formats.size());
  std::vector<VkAttachmentReference> refs(formats.size());
  for (size_t i = 0; i < formats.size(); ++i) {
    VkAttachmentDescription& a = attachments[i];
    a.format = formats[i];
    a.samples = VK_SAMPLE_COUNT_1_BIT;
    a.loadOp = load;
    a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    a.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    a.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    a.initialLayout = initial;
    a.finalLayout = final_layout;
    refs[i] = {static_cast<uint32_t>(i), VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  }
  VkSubpassDescription sub{};
  sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  sub.colorAttachmentCount = static_cast<uint32_t>(refs.size());
  sub.pColorAttachments = refs.data();
  VkSubpassDependency deps[2] = {};
  deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
  deps[0].dstSubpass = 0;
  deps[0].srcStageMask = before.stage;
  deps[0].srcAccessMask = before.access;
  deps[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_READ_BIT;
  deps[1].srcSubpass = 0;
  deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
  deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  deps[1].dstStageMask = after.stage;
  deps[1].dstAccessMask = after.access;
  VkRenderPassCreateInfo info{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  info.attachmentCount = static_cast<uint32_t>(attachments.size());
  info.pAttachments = attachments.data();
  info.subpassCount = 1;
  info.pSubpasses = &sub;
  info.dependencyCount = 2;
  info.pDependencies = deps;
  VkRenderPass pass;
  DYPHO_VK(vkCreateRenderPass(device, &info, nullptr, &pass));
  return pass;
}

VkPipeline CreateGraphicsPipeline(Context* context, const GraphicsPipelineDesc& desc) {
  VkDevice d = context->device();
  VkShaderModule modules[2] = {context->CreateShader(desc.vertex_shader), VK_NULL_HANDLE};
  try {
    modules[1] = context->CreateShader(desc.fragment_shader);
  } catch (...) {
    vkDestroyShaderModule(d, modules[0], nullptr);
    throw;
  }
  VkPipelineShaderStageCreateInfo stages[2] = {{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO},
                                               {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO}};
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  for (int i = 0; i < 2; ++i) {
    stages[i].module = modules[i];
    stages[i].pName = "main";
  }
  VkPipelineVertexInputStateCreateInfo vi{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vi.vertexBindingDescriptionCount = static_cast<uint32_t>(desc.bindings.size());
  vi.pVertexBindingDescriptions = desc.bindings.data();
  vi.vertexAttributeDescriptionCount = static_cast<uint32_t>(desc.attributes.size());
  vi.pVertexAttributeDescriptions = desc.attributes.data();
  VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = desc.topology;
  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.cullMode = VK_CULL_MODE_NONE;
  rs.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  rs.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = static_cast<uint32_t>(desc.blend.size());
  cb.pAttachments = desc.blend.data();
  const VkDynamicState dyn_states[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dyn{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dyn.dynamicStateCount = 2;
  dyn.pDynamicStates = dyn_states;
  VkGraphicsPipelineCreateInfo gp{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  gp.stageCount = 2;
  gp.pStages = stages;
  gp.pVertexInputState = &vi;
  gp.pInputAssemblyState = &ia;
  gp.pViewportState = &vp;
  gp.pRasterizationState = &rs;
  gp.pMultisampleState = &ms;
  gp.pColorBlendState = &cb;
  gp.pDynamicState = &dyn;
  gp.layout = desc.layout;
  gp.renderPass = desc.render_pass;
  gp.subpass = 0;
  VkPipeline pipeline = VK_NULL_HANDLE;
  const VkResult r = vkCreateGraphicsPipelines(d, VK_NULL_HANDLE, 1, &gp, nullptr, &pipeline);
  vkDestroyShaderModule(d, modules[0], nullptr);
  vkDestroyShaderModule(d, modules[1], nullptr);
  DYPHO_VK(r);
  return pipeline;
}

}  // namespace dypho::vulkan
