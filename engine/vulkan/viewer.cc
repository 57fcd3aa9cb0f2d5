#include "engine/vulkan/viewer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>

#include <Eigen/Geometry>
#define GLFW_INCLUDE_NONE
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include "common/check.h"
#include "engine/io/image_io.h"
#include "engine/render/offline_render.h"
#include "engine/render/render.h"
#include "engine/vulkan/splat_renderer.h"
#include "engine/vulkan/vk_context.h"

namespace dypho::vulkan {
namespace {

constexpr double kOrbitElevation = 0.35;  // OrbitOptions default: pose 0 of `dypho render --orbit`

struct LineVertex {
  float pos[3];
  float color[3];
};

// Camera state driven by the mouse and keyboard.
struct ViewState {
  // orbit
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 1.0, theta = 0.0, elevation = kOrbitElevation;
  Eigen::Vector3d up{0, -1, 0};
  // fly
  bool fly = false;
  Rigid3d fly_pose;  // world_from_cam
  // custom start
  std::optional<Rigid3d> fixed_pose;  // until the first input
  // toggles
  bool oit = false, points = false, overlay = true;
  bool screenshot_requested = false, reset_requested = false;
  // mouse
  bool left = false, right = false;
  double last_x = 0, last_y = 0;

  Rigid3d WorldFromCam() const {
    if (fixed_pose) return *fixed_pose;
    if (fly) return fly_pose;
    return OrbitPose(centre, radius, theta, elevation, up);
  }
  void Touch() {
    if (fixed_pose) {
      // Start the interaction from the fixed pose: fly from there.
      fly = true;
      fly_pose = *fixed_pose;
      fixed_pose.reset();
    }
  }
};

ViewState* State(GLFWwindow* w) { return static_cast<ViewState*>(glfwGetWindowUserPointer(w)); }

void OnKey(GLFWwindow* w, int key, int, int action, int) {
  if (action != GLFW_PRESS) return;
  ViewState* s = State(w);
  switch (key) {
    case GLFW_KEY_ESCAPE:
      glfwSetWindowShouldClose(w, GLFW_TRUE);
      break;
    case GLFW_KEY_TAB:
      if (!s->fly) s->fly_pose = s->WorldFromCam();
      s->fixed_pose.reset();
      s->fly = !s->fly;
      break;
    case GLFW_KEY_M:
      s->oit = !s->oit;
      break;
    case GLFW_KEY_P:
      s->points = !s->points;
      break;
    case GLFW_KEY_T:
      s->overlay = !s->overlay;
      break;
    case GLFW_KEY_C:
      s->screenshot_requested = true;
      break;
    case GLFW_KEY_R:
      s->reset_requested = true;
      break;
    default:
      break;
  }
}

void OnButton(GLFWwindow* w, int button, int action, int) {
  ViewState* s = State(w);
  if (button == GLFW_MOUSE_BUTTON_LEFT) s->left = action == GLFW_PRESS;
  if (button == GLFW_MOUSE_BUTTON_RIGHT || button == GLFW_MOUSE_BUTTON_MIDDLE) s->right = action == GLFW_PRESS;
  glfwGetCursorPos(w, &s->last_x, &s->last_y);
}

void OnCursor(GLFWwindow* w, double x, double y) {
  ViewState* s = State(w);
  const double dx = x - s->last_x, dy = y - s->last_y;
  s->last_x = x;
  s->last_y = y;
  if (!s->left && !s->right) return;
  s->Touch();
  const Eigen::Vector3d up = s->up.normalized();
  if (s->fly) {
    if (s->left) {
      // yaw about world up, pitch about the camera's x axis
      const Eigen::Quaterniond yaw(Eigen::AngleAxisd(-0.004 * dx, -up));
      const Eigen::Vector3d x_axis = s->fly_pose.rotation * Eigen::Vector3d::UnitX();
      const Eigen::Quaterniond pitch(Eigen::AngleAxisd(-0.004 * dy, x_axis));
      s->fly_pose.rotation = (yaw * pitch * s->fly_pose.rotation).normalized();
    }
    return;
  }
  if (s->left) {
    s->theta -= 0.01 * dx;
    s->elevation = std::clamp(s->elevation + 0.01 * dy, -1.5, 1.5);
  } else if (s->right) {
    const Rigid3d pose = s->WorldFromCam();
    const double k = 0.0015 * s->radius;
    s->centre += pose.rotation * Eigen::Vector3d(-k * dx, -k * dy, 0.0);
  }
}

void OnScroll(GLFWwindow* w, double, double dy) {
  ViewState* s = State(w);
  s->Touch();
  if (s->fly) {
    s->fly_pose.translation += s->fly_pose.rotation * Eigen::Vector3d(0, 0, 0.1 * dy);
  } else {
    s->radius = std::max(1e-3, s->radius * std::pow(0.9, dy));
  }
}

// Pixel (u, v) -> Vulkan clip space for the pinhole camera: the splat
// renderer's convention (centre of pixel u at framebuffer u + 0.5).
Eigen::Matrix4f ClipFromWorld(const Camera& c, const Rigid3d& cam_from_world) {
  Eigen::Matrix4d P = Eigen::Matrix4d::Zero();
  P(0, 0) = 2.0 * c.fx / c.width;
  P(0, 2) = 2.0 * (c.cx + 0.5) / c.width - 1.0;
  P(1, 1) = 2.0 * c.fy / c.height;
  P(1, 2) = 2.0 * (c.cy + 0.5) / c.height - 1.0;
  P(2, 2) = 0.5;  // constant NDC depth 0.5; points behind the camera have w < 0 and are clipped
  P(3, 2) = 1.0;
  return (P * cam_from_world.ToMatrix4()).cast<float>();
}

// Trajectory polyline (yellow) and keyframe frusta (cyan) as a line list.
std::vector<LineVertex> OverlayLines(const ViewerOptions& o, const Camera& camera, double frustum) {
  std::vector<LineVertex> v;
  auto add = [&v](const Eigen::Vector3d& a, const Eigen::Vector3d& b, float r, float g, float bl) {
    v.push_back({{float(a.x()), float(a.y()), float(a.z())}, {r, g, bl}});
    v.push_back({{float(b.x()), float(b.y()), float(b.z())}, {r, g, bl}});
  };
  for (size_t i = 1; i < o.trajectory.size(); ++i) {
    add(o.trajectory.world_from_cam[i - 1].translation, o.trajectory.world_from_cam[i].translation, 1.0f, 0.85f, 0.1f);
  }
  for (const Rigid3d& kf : o.keyframes) {
    const Eigen::Vector2d px[4] = {{-0.5, -0.5},
                                   {camera.width - 0.5, -0.5},
                                   {camera.width - 0.5, camera.height - 0.5},
                                   {-0.5, camera.height - 0.5}};
    Eigen::Vector3d corner[4];
    for (int k = 0; k < 4; ++k) corner[k] = kf * camera.Unproject(px[k], frustum);
    for (int k = 0; k < 4; ++k) {
      add(kf.translation, corner[k], 0.2f, 0.9f, 1.0f);
      add(corner[k], corner[(k + 1) % 4], 0.2f, 0.9f, 1.0f);
    }
  }
  return v;
}

class Viewer {
 public:
  Viewer(const GaussianCloud& cloud, const ViewerOptions& options);
  ~Viewer();
  int Run();

 private:
  void CreateSwapchain();
  void DestroySwapchain();
  void CreateOverlayPipeline();
  Camera FrameCamera() const;
  void SaveScreenshot(const std::string& path);

  const GaussianCloud& cloud_;
  ViewerOptions options_;
  ViewState state_;
  ViewState initial_state_;
  GLFWwindow* window_ = nullptr;
  std::unique_ptr<Context> ctx_;
  std::unique_ptr<SplatRenderer> splats_;
  VkSurfaceKHR surface_ = VK_NULL_HANDLE;
  VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
  VkFormat swap_format_ = VK_FORMAT_UNDEFINED;
  VkExtent2D extent_{};
  bool swap_readable_ = false;
  std::vector<VkImage> swap_images_;
  Image display_;
  VkRenderPass overlay_pass_ = VK_NULL_HANDLE;
  VkFramebuffer overlay_fb_ = VK_NULL_HANDLE;
  VkPipelineLayout overlay_layout_ = VK_NULL_HANDLE;
  VkPipeline overlay_pipeline_ = VK_NULL_HANDLE;
  Buffer lines_;
  uint32_t line_vertices_ = 0;
  Buffer readback_;
  VkSemaphore acquired_ = VK_NULL_HANDLE, rendered_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
};

Viewer::Viewer(const GaussianCloud& cloud, const ViewerOptions& options) : cloud_(cloud), options_(options) {
  if (!options_.camera.IsValid(nullptr)) options_.camera = Camera::FromFov(1280, 720, 60.0 * M_PI / 180.0);
  options_.camera.Validate("viewer camera");
  std::string error;
  DYPHO_CHECK_INPUT(options_.settings.IsValid(&error)) << "viewer settings: " << error;
  DYPHO_CHECK_INPUT(options_.frames >= 0) << "viewer frames must be >= 0 (got " << options_.frames << ")";
  cloud.Validate("viewer map");

  // Start view: pose 0 of `dypho render --orbit` (or the given pose).
  state_.oit = options_.settings.mode == kernels::CompositeMode::kOrderIndependent;
  state_.points = options_.points;
  if (!cloud.empty()) {
    try {
      state_.centre = MapCentre(cloud);
      state_.radius = AutoOrbitRadius(cloud, state_.centre);
    } catch (const InvalidInput&) {
      // no finite mean: orbit the origin
    }
  }
  state_.fixed_pose = options_.start_pose;
  initial_state_ = state_;
  const double frustum = options_.frustum_size > 0 ? options_.frustum_size : 0.05 * state_.radius;

  if (!glfwInit()) {
    throw VulkanError(
        "cannot open a window: no display (set DISPLAY, or run under `xvfb-run -a` "
        "from the Debian package xvfb)");
  }
  if (!glfwVulkanSupported()) {
    glfwTerminate();
    throw VulkanError("GLFW finds no Vulkan loader/driver: install libvulkan1 and mesa-vulkan-drivers");
  }
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
  window_ = glfwCreateWindow(options_.camera.width, options_.camera.height, "dypho view", nullptr, nullptr);
  if (!window_) {
    glfwTerminate();
    throw VulkanError("cannot create a window (glfwCreateWindow failed)");
  }
  glfwSetWindowUserPointer(window_, &state_);
  glfwSetKeyCallback(window_, OnKey);
  glfwSetMouseButtonCallback(window_, OnButton);
  glfwSetCursorPosCallback(window_, OnCursor);
  glfwSetScrollCallback(window_, OnScroll);

  ContextOptions co;
  co.validation = options_.validation;
  co.swapchain = true;
  uint32_t count = 0;
  const char** ext = glfwGetRequiredInstanceExtensions(&count);
  for (uint32_t i = 0; i < count; ++i) co.instance_extensions.push_back(ext[i]);
  ctx_ = std::make_unique<Context>(co);
  DYPHO_VK(glfwCreateWindowSurface(ctx_->instance(), window_, nullptr, &surface_));
  VkBool32 present = VK_FALSE;
  DYPHO_VK(vkGetPhysicalDeviceSurfaceSupportKHR(ctx_->physical_device(), ctx_->queue_family(), surface_, &present));
  if (!present) throw VulkanError("the chosen Vulkan device cannot present to this window");
  splats_ = std::make_unique<SplatRenderer>(ctx_.get());
  splats_->SetMap(cloud);

  const std::vector<LineVertex> lines = OverlayLines(options_, options_.camera, frustum);
  line_vertices_ = static_cast<uint32_t>(lines.size());
  lines_ = ctx_->CreateBuffer(sizeof(LineVertex) * std::max<size_t>(1, lines.size()), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                              true);
  if (!lines.empty()) std::memcpy(lines_.mapped, lines.data(), sizeof(LineVertex) * lines.size());

  VkSemaphoreCreateInfo si{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  DYPHO_VK(vkCreateSemaphore(ctx_->device(), &si, nullptr, &acquired_));
  DYPHO_VK(vkCreateSemaphore(ctx_->device(), &si, nullptr, &rendered_));
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  DYPHO_VK(vkCreateFence(ctx_->device(), &fi, nullptr, &fence_));
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = ctx_->command_pool();
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  DYPHO_VK(vkAllocateCommandBuffers(ctx_->device(), &ai, &cmd_));
  CreateSwapchain();
}

Viewer::~Viewer() {
  if (ctx_) {
    VkDevice d = ctx_->device();
    vkDeviceWaitIdle(d);
    DestroySwapchain();
    if (overlay_pipeline_) vkDestroyPipeline(d, overlay_pipeline_, nullptr);
    if (overlay_layout_) vkDestroyPipelineLayout(d, overlay_layout_, nullptr);
    if (overlay_pass_) vkDestroyRenderPass(d, overlay_pass_, nullptr);
    ctx_->Destroy(&lines_);
    if (acquired_) vkDestroySemaphore(d, acquired_, nullptr);
    if (rendered_) vkDestroySemaphore(d, rendered_, nullptr);
    if (fence_) vkDestroyFence(d, fence_, nullptr);
    if (cmd_) vkFreeCommandBuffers(d, ctx_->command_pool(), 1, &cmd_);
    splats_.reset();
    if (surface_) vkDestroySurfaceKHR(ctx_->instance(), surface_, nullptr);
    ctx_.reset();
  }
  if (window_) glfwDestroyWindow(window_);
  glfwTerminate();
}

void Viewer::CreateSwapchain() {
  VkPhysicalDevice pd = ctx_->physical_device();
  VkSurfaceCapabilitiesKHR caps;
  DYPHO_VK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(pd, surface_, &caps));
  uint32_t nf = 0;
  DYPHO_VK(vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface_, &nf, nullptr));
  std::vector<VkSurfaceFormatKHR> formats(nf);
  DYPHO_VK(vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface_, &nf, formats.data()));
  // Linear UNORM so the window shows the same 8-bit values as the PNGs.
  VkSurfaceFormatKHR chosen = formats.empty() ? VkSurfaceFormatKHR{} : formats[0];
  for (const auto& f : formats) {
    if (f.format == VK_FORMAT_B8G8R8A8_UNORM || f.format == VK_FORMAT_R8G8B8A8_UNORM) {
      chosen = f;
      break;
    }
  }
  if (chosen.format != VK_FORMAT_B8G8R8A8_UNORM && chosen.format != VK_FORMAT_R8G8B8A8_UNORM) {
    throw VulkanError("the window surface offers no 8-bit UNORM RGBA/BGRA format");
  }
  if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT)) {
    throw VulkanError("the window surface cannot be a transfer destination");
  }
  swap_readable_ = (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) != 0;
  extent_ = caps.currentExtent;
  if (extent_.width == UINT32_MAX) {
    int w = 0, h = 0;
    glfwGetFramebufferSize(window_, &w, &h);
    extent_ = {uint32_t(std::max(1, w)), uint32_t(std::max(1, h))};
  }
  extent_.width = std::clamp(extent_.width, caps.minImageExtent.width, caps.maxImageExtent.width);
  extent_.height = std::clamp(extent_.height, caps.minImageExtent.height, caps.maxImageExtent.height);
  swap_format_ = chosen.format;
  VkSwapchainCreateInfoKHR sci{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  sci.surface = surface_;
  sci.minImageCount = std::max(caps.minImageCount, 2u);
  if (caps.maxImageCount > 0) sci.minImageCount = std::min(sci.minImageCount, caps.maxImageCount);
  sci.imageFormat = chosen.format;
  sci.imageColorSpace = chosen.colorSpace;
  sci.imageExtent = extent_;
  sci.imageArrayLayers = 1;
  sci.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | (swap_readable_ ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0);
  sci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  sci.preTransform = caps.currentTransform;
  sci.compositeAlpha = (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
                           ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                           : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha);
  sci.presentMode = VK_PRESENT_MODE_FIFO_KHR;  // always supported
  sci.clipped = VK_TRUE;
  DYPHO_VK(vkCreateSwapchainKHR(ctx_->device(), &sci, nullptr, &swapchain_));
  uint32_t ni = 0;
  DYPHO_VK(vkGetSwapchainImagesKHR(ctx_->device(), swapchain_, &ni, nullptr));
  swap_images_.resize(ni);
  DYPHO_VK(vkGetSwapchainImagesKHR(ctx_->device(), swapchain_, &ni, swap_images_.data()));

  display_ = ctx_->CreateImage(
      extent_.width, extent_.height, VK_FORMAT_R8G8B8A8_UNORM,
      VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
  readback_ =
      ctx_->CreateBuffer(VkDeviceSize(extent_.width) * extent_.height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
  if (!overlay_pass_) CreateOverlayPipeline();
  VkFramebufferCreateInfo fb{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
  fb.renderPass = overlay_pass_;
  fb.attachmentCount = 1;
  fb.pAttachments = &display_.view;
  fb.width = extent_.width;
  fb.height = extent_.height;
  fb.layers = 1;
  DYPHO_VK(vkCreateFramebuffer(ctx_->device(), &fb, nullptr, &overlay_fb_));
}

void Viewer::DestroySwapchain() {
  VkDevice d = ctx_->device();
  if (overlay_fb_) vkDestroyFramebuffer(d, overlay_fb_, nullptr);
  overlay_fb_ = VK_NULL_HANDLE;
  ctx_->Destroy(&display_);
  ctx_->Destroy(&readback_);
  if (swapchain_) vkDestroySwapchainKHR(d, swapchain_, nullptr);
  swapchain_ = VK_NULL_HANDLE;
  swap_images_.clear();
}

void Viewer::CreateOverlayPipeline() {
  VkDevice d = ctx_->device();
  // Lines drawn over the splat image the resolve pass wrote, then copied to
  // the swapchain image.
  overlay_pass_ = CreateColorRenderPass(d, {VK_FORMAT_R8G8B8A8_UNORM}, VK_ATTACHMENT_LOAD_OP_LOAD,
                                        VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                        {VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_WRITE_BIT},
                                        {VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_READ_BIT});

  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT, 0, 64};
  VkPipelineLayoutCreateInfo li{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  DYPHO_VK(vkCreatePipelineLayout(d, &li, nullptr, &overlay_layout_));

  GraphicsPipelineDesc lines;
  lines.vertex_shader = "overlay.vert";
  lines.fragment_shader = "overlay.frag";
  lines.topology = VK_PRIMITIVE_TOPOLOGY_LINE_LIST;
  lines.bindings = {{0, sizeof(LineVertex), VK_VERTEX_INPUT_RATE_VERTEX}};
  lines.attributes = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0}, {1, 0, VK_FORMAT_R32G32B32_SFLOAT, 12}};
  VkPipelineColorBlendAttachmentState blend{};
  blend.colorWriteMask =
      VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  lines.blend = {blend};
  lines.layout = overlay_layout_;
  lines.render_pass = overlay_pass_;
  overlay_pipeline_ = CreateGraphicsPipeline(ctx_.get(), lines);
}

// The camera for the current framebuffer: the option's intrinsics, scaled
// when the window's framebuffer differs in size (HiDPI, resizing).
Camera Viewer::FrameCamera() const {
  Camera c = options_.camera;
  if (int(extent_.width) == c.width && int(extent_.height) == c.height) return c;
  const double sx = double(extent_.width) / c.width, sy = double(extent_.height) / c.height;
  c.fx *= sx;
  c.fy *= sy;
  c.cx = (c.cx + 0.5) * sx - 0.5;
  c.cy = (c.cy + 0.5) * sy - 0.5;
  c.width = int(extent_.width);
  c.height = int(extent_.height);
  return c;
}

void Viewer::SaveScreenshot(const std::string& path) {
  const uint8_t* px = static_cast<const uint8_t*>(readback_.mapped);
  ImageU8 rgb(int(extent_.width), int(extent_.height), 3);
  const bool bgra = swap_readable_ && swap_format_ == VK_FORMAT_B8G8R8A8_UNORM;
  for (size_t i = 0; i < size_t(extent_.width) * extent_.height; ++i) {
    for (int c = 0; c < 3; ++c) rgb.data()[3 * i + c] = px[4 * i + (bgra ? 2 - c : c)];
  }
  WriteRgb8(path, rgb);
  std::printf("dypho view: screenshot %ux%u -> %s\n", extent_.width, extent_.height, path.c_str());
}

int Viewer::Run() {
  VkDevice d = ctx_->device();
  int frame = 0, shots = 0;
  auto last = std::chrono::steady_clock::now();
  double fps = 0;
  std::printf(
      "dypho view: %d Gaussians. Left drag orbit, right drag pan, wheel zoom; Tab fly (WASD QE), M mode, "
      "P points, T trajectory, C screenshot, R reset, Esc quit\n",
      cloud_.size());
  while (!glfwWindowShouldClose(window_)) {
    glfwPollEvents();
    const auto now = std::chrono::steady_clock::now();
    const double dt = std::chrono::duration<double>(now - last).count();
    last = now;
    fps = fps == 0 ? 1.0 / std::max(dt, 1e-6) : 0.9 * fps + 0.1 / std::max(dt, 1e-6);
    if (state_.reset_requested) {
      const bool oit = state_.oit, points = state_.points, overlay = state_.overlay;
      state_ = initial_state_;
      state_.oit = oit;
      state_.points = points;
      state_.overlay = overlay;
    }
    if (state_.fly && !state_.fixed_pose) {
      const double speed =
          0.5 * state_.radius * dt * (glfwGetKey(window_, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS ? 5.0 : 1.0);
      Eigen::Vector3d move = Eigen::Vector3d::Zero();
      if (glfwGetKey(window_, GLFW_KEY_W) == GLFW_PRESS) move.z() += 1;
      if (glfwGetKey(window_, GLFW_KEY_S) == GLFW_PRESS) move.z() -= 1;
      if (glfwGetKey(window_, GLFW_KEY_D) == GLFW_PRESS) move.x() += 1;
      if (glfwGetKey(window_, GLFW_KEY_A) == GLFW_PRESS) move.x() -= 1;
      if (glfwGetKey(window_, GLFW_KEY_Q) == GLFW_PRESS) move.y() += 1;
      if (glfwGetKey(window_, GLFW_KEY_E) == GLFW_PRESS) move.y() -= 1;
      state_.fly_pose.translation += state_.fly_pose.rotation * (speed * move);
    }

    uint32_t index = 0;
    VkResult r = vkAcquireNextImageKHR(d, swapchain_, UINT64_MAX, acquired_, VK_NULL_HANDLE, &index);
    if (r == VK_ERROR_OUT_OF_DATE_KHR) {
      vkDeviceWaitIdle(d);
      DestroySwapchain();
      CreateSwapchain();
      continue;
    }
    if (r != VK_SUBOPTIMAL_KHR) DYPHO_VK(r);

    const Camera camera = FrameCamera();
    const Rigid3d cam_from_world = state_.WorldFromCam().Inverse();
    kernels::RasterSettings settings = options_.settings;
    settings.mode = state_.oit ? kernels::CompositeMode::kOrderIndependent : kernels::CompositeMode::kSorted;
    SplatDrawOptions draw;
    draw.points = state_.points;
    draw.point_radius = options_.point_radius;
    const bool auto_shot = !options_.screenshot.empty() && frame + 1 == std::max(1, options_.frames);
    const bool shot = auto_shot || state_.screenshot_requested;

    DYPHO_VK(vkResetCommandBuffer(cmd_, 0));
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    DYPHO_VK(vkBeginCommandBuffer(cmd_, &begin));
    splats_->Record(cmd_, ToRasterCamera(camera, cam_from_world), settings, draw, &display_);
    // Overlay lines on the display image (GENERAL -> TRANSFER_SRC).
    VkRenderPassBeginInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    rp.renderPass = overlay_pass_;
    rp.framebuffer = overlay_fb_;
    rp.renderArea = {{0, 0}, extent_};
    vkCmdBeginRenderPass(cmd_, &rp, VK_SUBPASS_CONTENTS_INLINE);
    if (state_.overlay && line_vertices_ > 0) {
      vkCmdBindPipeline(cmd_, VK_PIPELINE_BIND_POINT_GRAPHICS, overlay_pipeline_);
      VkViewport viewport{0, 0, float(extent_.width), float(extent_.height), 0, 1};
      VkRect2D scissor{{0, 0}, extent_};
      vkCmdSetViewport(cmd_, 0, 1, &viewport);
      vkCmdSetScissor(cmd_, 0, 1, &scissor);
      const Eigen::Matrix4f m = ClipFromWorld(camera, cam_from_world);
      vkCmdPushConstants(cmd_, overlay_layout_, VK_SHADER_STAGE_VERTEX_BIT, 0, 64, m.data());
      VkDeviceSize offset = 0;
      vkCmdBindVertexBuffers(cmd_, 0, 1, &lines_.buffer, &offset);
      vkCmdDraw(cmd_, line_vertices_, 1, 0, 0);
    }
    vkCmdEndRenderPass(cmd_);
    // Blit to the swapchain image (converts RGBA to the swapchain's order).
    VkImage swap = swap_images_[index];
    TransitionImage(cmd_, swap, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0,
                    VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    VkImageBlit blit{};
    blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    blit.srcOffsets[1] = {int32_t(extent_.width), int32_t(extent_.height), 1};
    blit.dstOffsets[1] = {int32_t(extent_.width), int32_t(extent_.height), 1};
    vkCmdBlitImage(cmd_, display_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, swap,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_NEAREST);
    VkImageLayout swap_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    if (shot) {
      // Read back what is presented (the swapchain image) when allowed,
      // else the display image it was copied from.
      VkImage src = display_.image;
      if (swap_readable_) {
        TransitionImage(cmd_, swap, swap_layout, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT,
                        VK_ACCESS_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
        swap_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        src = swap;
      }
      VkBufferImageCopy region{};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {extent_.width, extent_.height, 1};
      vkCmdCopyImageToBuffer(cmd_, src, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback_.buffer, 1, &region);
      StageBarrier(cmd_, VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                   VK_PIPELINE_STAGE_HOST_BIT);
    }
    TransitionImage(cmd_, swap, swap_layout, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_ACCESS_TRANSFER_WRITE_BIT, 0,
                    VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
    DYPHO_VK(vkEndCommandBuffer(cmd_));

    const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.waitSemaphoreCount = 1;
    submit.pWaitSemaphores = &acquired_;
    submit.pWaitDstStageMask = &wait_stage;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd_;
    submit.signalSemaphoreCount = 1;
    submit.pSignalSemaphores = &rendered_;
    DYPHO_VK(vkResetFences(d, 1, &fence_));
    DYPHO_VK(vkQueueSubmit(ctx_->queue(), 1, &submit, fence_));
    VkPresentInfoKHR present{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
    present.waitSemaphoreCount = 1;
    present.pWaitSemaphores = &rendered_;
    present.swapchainCount = 1;
    present.pSwapchains = &swapchain_;
    present.pImageIndices = &index;
    r = vkQueuePresentKHR(ctx_->queue(), &present);
    DYPHO_VK(vkWaitForFences(d, 1, &fence_, VK_TRUE, UINT64_MAX));
    if (shot) {
      if (auto_shot) SaveScreenshot(options_.screenshot);
      if (state_.screenshot_requested) {
        char name[64];
        std::snprintf(name, sizeof(name), "screenshot_%04d.png", shots++);
        SaveScreenshot(name);
        state_.screenshot_requested = false;
      }
    }
    if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) {
      vkDeviceWaitIdle(d);
      DestroySwapchain();
      CreateSwapchain();
    } else {
      DYPHO_VK(r);
    }
    ++frame;
    if (frame % 10 == 0) {
      char title[256];
      std::snprintf(title, sizeof(title), "dypho view - %s, %s, %s - %d Gaussians - %.1f fps",
                    state_.oit ? "order-independent" : "sorted", state_.points ? "points" : "ellipses",
                    state_.fly ? "fly" : "orbit", cloud_.size(), fps);
      glfwSetWindowTitle(window_, title);
    }
    if (options_.frames > 0 && frame >= options_.frames) break;
  }
  vkDeviceWaitIdle(d);
  if (ctx_->validation_messages() > 0) {
    std::fprintf(stderr, "dypho view: the Vulkan validation layer reported %d problems\n", ctx_->validation_messages());
    return 1;
  }
  return 0;
}

}  // namespace

int RunViewer(const GaussianCloud& cloud, const ViewerOptions& options) {
  Viewer viewer(cloud, options);
  return viewer.Run();
}

}  // namespace dypho::vulkan
