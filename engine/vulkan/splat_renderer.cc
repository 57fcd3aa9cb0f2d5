#include "engine/vulkan/splat_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "common/check.h"
#include "kernels/math/preprocess.h"

namespace dypho::vulkan {
namespace {

constexpr VkFormat kAccFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr uint32_t kProjectGroup = 128;  // project.comp local size
constexpr uint32_t kSortGroup = 64;      // radix_hist/scatter local size

// std140 layout of splat_common.glsl CameraBlock.
struct CameraBlock {
  float rot0[4], rot1[4], rot2[4];
  float center[4];
  float intrinsics[4];
  float limits[4];
  float planes[4];
  int32_t size[4];
  int32_t options[4];
};

struct SortPush {
  uint32_t n, shift, items, threads;
};
struct ScanPush {
  uint32_t count;
};
struct DrawPush {
  float viewport[4];
  uint32_t use_order, points;
  float point_radius;
  uint32_t oit;
  uint32_t quad_vertices;
};
struct ResolvePush {
  float background[4];
  uint32_t width, height, oit, to_display;
};

VkDescriptorSetLayout MakeSetLayout(VkDevice device, const std::vector<VkDescriptorType>& types,
                                    VkShaderStageFlags stages) {
  std::vector<VkDescriptorSetLayoutBinding> bindings(types.size());
  for (size_t i = 0; i < types.size(); ++i) {
    bindings[i].binding = static_cast<uint32_t>(i);
    bindings[i].descriptorType = types[i];
    bindings[i].descriptorCount = 1;
    bindings[i].stageFlags = stages;
  }
  VkDescriptorSetLayoutCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  info.bindingCount = static_cast<uint32_t>(bindings.size());
  info.pBindings = bindings.data();
  VkDescriptorSetLayout layout;
  DYPHO_VK(vkCreateDescriptorSetLayout(device, &info, nullptr, &layout));
  return layout;
}

VkPipelineLayout MakePipelineLayout(VkDevice device, VkDescriptorSetLayout set, uint32_t push_size,
                                    VkShaderStageFlags push_stages) {
  VkPushConstantRange range{push_stages, 0, push_size};
  VkPipelineLayoutCreateInfo info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = 1;
  info.pSetLayouts = &set;
  info.pushConstantRangeCount = push_size > 0 ? 1 : 0;
  info.pPushConstantRanges = &range;
  VkPipelineLayout layout;
  DYPHO_VK(vkCreatePipelineLayout(device, &info, nullptr, &layout));
  return layout;
}

VkPipeline MakeComputePipeline(Context* ctx, const char* shader, VkPipelineLayout layout) {
  VkShaderModule module = ctx->CreateShader(shader);
  VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = module;
  info.stage.pName = "main";
  info.layout = layout;
  VkPipeline pipeline;
  const VkResult r = vkCreateComputePipelines(ctx->device(), VK_NULL_HANDLE, 1, &info, nullptr, &pipeline);
  vkDestroyShaderModule(ctx->device(), module, nullptr);
  DYPHO_VK(r);
  return pipeline;
}

void WriteBuffer(VkDevice device, VkDescriptorSet set, uint32_t binding, VkDescriptorType type, const Buffer& b) {
  VkDescriptorBufferInfo info{b.buffer, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  w.dstSet = set;
  w.dstBinding = binding;
  w.descriptorCount = 1;
  w.descriptorType = type;
  w.pBufferInfo = &info;
  vkUpdateDescriptorSets(device, 1, &w, 0, nullptr);
}

void WriteStorageImage(VkDevice device, VkDescriptorSet set, uint32_t binding, VkImageView view) {
  VkDescriptorImageInfo info{VK_NULL_HANDLE, view, VK_IMAGE_LAYOUT_GENERAL};
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  w.dstSet = set;
  w.dstBinding = binding;
  w.descriptorCount = 1;
  w.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  w.pImageInfo = &info;
  vkUpdateDescriptorSets(device, 1, &w, 0, nullptr);
}

constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
constexpr VkBufferUsageFlags kUpload = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;

}  // namespace

SplatRenderer::SplatRenderer(Context* context) : ctx_(context) {
  try {
    CreatePipelines();
    if (ctx_->properties().limits.timestampComputeAndGraphics) {
      VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
      qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
      qi.queryCount = 5;
      DYPHO_VK(vkCreateQueryPool(ctx_->device(), &qi, nullptr, &timestamps_));
    }
    camera_ubo_ = ctx_->CreateBuffer(sizeof(CameraBlock), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, true);
    stats_ = ctx_->CreateBuffer(16, kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
    dummy_display_ = ctx_->CreateImage(1, 1, VK_FORMAT_R8G8B8A8_UNORM, VK_IMAGE_USAGE_STORAGE_BIT);
    VkCommandBuffer cmd = ctx_->BeginOneShot();
    TransitionImage(cmd, dummy_display_.image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL, 0,
                    VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT,
                    VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
    ctx_->SubmitAndWait(cmd);
    SetMap(GaussianCloud{});
  } catch (...) {
    Release();
    throw;
  }
}

SplatRenderer::~SplatRenderer() { Release(); }

void SplatRenderer::Release() {
  VkDevice d = ctx_->device();
  if (d == VK_NULL_HANDLE) return;
  vkDeviceWaitIdle(d);
  DestroyMap();
  DestroyTargets();
  ctx_->Destroy(&camera_ubo_);
  ctx_->Destroy(&stats_);
  ctx_->Destroy(&dummy_display_);
  ctx_->Destroy(&draw_args_);
  for (VkPipeline p : {project_, hist_, scan_, scatter_, draw_sorted_, draw_oit_, resolve_, args_}) {
    if (p) vkDestroyPipeline(d, p, nullptr);
  }
  for (VkPipelineLayout l : {project_pl_, hist_pl_, scan_pl_, scatter_pl_, draw_pl_, resolve_pl_, args_pl_}) {
    if (l) vkDestroyPipelineLayout(d, l, nullptr);
  }
  for (VkDescriptorSetLayout l :
       {project_layout_, hist_layout_, scan_layout_, scatter_layout_, draw_layout_, resolve_layout_, args_layout_}) {
    if (l) vkDestroyDescriptorSetLayout(d, l, nullptr);
  }
  if (pool_) vkDestroyDescriptorPool(d, pool_, nullptr);
  if (timestamps_) vkDestroyQueryPool(d, timestamps_, nullptr);
  timestamps_ = VK_NULL_HANDLE;
  if (render_pass_) vkDestroyRenderPass(d, render_pass_, nullptr);
  project_ = hist_ = scan_ = scatter_ = draw_sorted_ = draw_oit_ = resolve_ = args_ = VK_NULL_HANDLE;
  project_pl_ = hist_pl_ = scan_pl_ = scatter_pl_ = draw_pl_ = resolve_pl_ = args_pl_ = VK_NULL_HANDLE;
  project_layout_ = hist_layout_ = scan_layout_ = scatter_layout_ = draw_layout_ = resolve_layout_ = args_layout_ =
      VK_NULL_HANDLE;
  pool_ = VK_NULL_HANDLE;
  render_pass_ = VK_NULL_HANDLE;
}

void SplatRenderer::CreatePipelines() {
  VkDevice d = ctx_->device();
  const VkDescriptorType SB = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  const VkDescriptorType IMG = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  const VkShaderStageFlags CS = VK_SHADER_STAGE_COMPUTE_BIT;
  project_layout_ = MakeSetLayout(d, {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, SB, SB, SB, SB, SB, SB, SB, SB, SB}, CS);
  hist_layout_ = MakeSetLayout(d, {SB, SB}, CS);
  scan_layout_ = MakeSetLayout(d, {SB}, CS);
  scatter_layout_ = MakeSetLayout(d, {SB, SB, SB, SB, SB}, CS);
  draw_layout_ = MakeSetLayout(d, {SB, SB}, VK_SHADER_STAGE_VERTEX_BIT);
  resolve_layout_ = MakeSetLayout(d, {IMG, IMG, SB, IMG}, CS);
  args_layout_ = MakeSetLayout(d, {SB, SB}, CS);
  project_pl_ = MakePipelineLayout(d, project_layout_, 0, 0);
  hist_pl_ = MakePipelineLayout(d, hist_layout_, sizeof(SortPush), CS);
  scan_pl_ = MakePipelineLayout(d, scan_layout_, sizeof(ScanPush), CS);
  scatter_pl_ = MakePipelineLayout(d, scatter_layout_, sizeof(SortPush), CS);
  draw_pl_ =
      MakePipelineLayout(d, draw_layout_, sizeof(DrawPush), VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
  resolve_pl_ = MakePipelineLayout(d, resolve_layout_, sizeof(ResolvePush), CS);
  args_pl_ = MakePipelineLayout(d, args_layout_, 0, 0);
  project_ = MakeComputePipeline(ctx_, "project.comp", project_pl_);
  hist_ = MakeComputePipeline(ctx_, "radix_hist.comp", hist_pl_);
  scan_ = MakeComputePipeline(ctx_, "radix_scan.comp", scan_pl_);
  scatter_ = MakeComputePipeline(ctx_, "radix_scatter.comp", scatter_pl_);
  resolve_ = MakeComputePipeline(ctx_, "resolve.comp", resolve_pl_);
  args_ = MakeComputePipeline(ctx_, "draw_args.comp", args_pl_);

  // Render pass: two float32 accumulation targets, cleared per mode, left in
  // GENERAL for the resolve pass's image loads.
  render_pass_ = CreateColorRenderPass(d, {kAccFormat, kAccFormat}, VK_ATTACHMENT_LOAD_OP_CLEAR,
                                       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL,
                                       {VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT},
                                       {VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_ACCESS_SHADER_READ_BIT});

  GraphicsPipelineDesc draw;
  draw.vertex_shader = "splat.vert";
  draw.fragment_shader = "splat.frag";
  draw.layout = draw_pl_;
  draw.render_pass = render_pass_;
  const VkColorComponentFlags all =
      VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  for (int oit = 0; oit < 2; ++oit) {
    draw.blend.assign(2, VkPipelineColorBlendAttachmentState{});
    for (auto& b : draw.blend) {
      b.blendEnable = VK_TRUE;
      b.colorWriteMask = all;
      b.colorBlendOp = VK_BLEND_OP_ADD;
      b.alphaBlendOp = VK_BLEND_OP_ADD;
    }
    if (!oit) {
      // Front to back with the transmittance T in the alpha channel (cleared
      // to 1): rgb += T * (alpha c), T *= (1 - alpha). Attachment 1 carries
      // alpha z and the same T.
      for (auto& b : draw.blend) {
        b.srcColorBlendFactor = VK_BLEND_FACTOR_DST_ALPHA;
        b.dstColorBlendFactor = VK_BLEND_FACTOR_ONE;
        b.srcAlphaBlendFactor = VK_BLEND_FACTOR_ZERO;
        b.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
      }
    } else {
      // Sums: (alpha f c, alpha f) and alpha f z; product of (1 - alpha) in
      // attachment 1's alpha (cleared to 1).
      VkPipelineColorBlendAttachmentState* blend = draw.blend.data();
      blend[0].srcColorBlendFactor = blend[0].dstColorBlendFactor = VK_BLEND_FACTOR_ONE;
      blend[0].srcAlphaBlendFactor = blend[0].dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
      blend[1].srcColorBlendFactor = blend[1].dstColorBlendFactor = VK_BLEND_FACTOR_ONE;
      blend[1].srcAlphaBlendFactor = VK_BLEND_FACTOR_ZERO;
      blend[1].dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
    }
    (oit ? draw_oit_ : draw_sorted_) = CreateGraphicsPipeline(ctx_, draw);
  }

  VkDescriptorPoolSize sizes[3] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
                                   {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 9 + 4 + 1 + 10 + 4 + 1 + 2},
                                   {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 3}};
  VkDescriptorPoolCreateInfo pool{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  pool.maxSets = 10;
  pool.poolSizeCount = 3;
  pool.pPoolSizes = sizes;
  DYPHO_VK(vkCreateDescriptorPool(d, &pool, nullptr, &pool_));
  VkDescriptorSetLayout layouts[10] = {project_layout_, hist_layout_, hist_layout_, scan_layout_,    scatter_layout_,
                                       scatter_layout_, draw_layout_, draw_layout_, resolve_layout_, args_layout_};
  VkDescriptorSet sets[10];
  VkDescriptorSetAllocateInfo alloc{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  alloc.descriptorPool = pool_;
  alloc.descriptorSetCount = 10;
  alloc.pSetLayouts = layouts;
  DYPHO_VK(vkAllocateDescriptorSets(d, &alloc, sets));
  project_set_ = sets[0];
  hist_sets_ = {sets[1], sets[2]};
  scan_set_ = sets[3];
  scatter_sets_ = {sets[4], sets[5]};
  draw_sets_ = {sets[6], sets[7]};
  resolve_set_ = sets[8];
  args_set_ = sets[9];
  draw_args_ = ctx_->CreateBuffer(9 * sizeof(uint32_t),
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, false);
  WriteBuffer(d, args_set_, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, draw_args_);
}

void SplatRenderer::DestroyMap() {
  for (Buffer* b : {&means_, &log_scales_, &quats_, &logits_, &sh_, &splats_, &keys_[0], &keys_[1], &values_[0],
                    &values_[1], &hist_buf_, &indices_}) {
    ctx_->Destroy(b);
  }
}

void SplatRenderer::DestroyTargets() {
  if (framebuffer_) vkDestroyFramebuffer(ctx_->device(), framebuffer_, nullptr);
  framebuffer_ = VK_NULL_HANDLE;
  ctx_->Destroy(&acc0_);
  ctx_->Destroy(&acc1_);
  ctx_->Destroy(&out_);
  width_ = height_ = 0;
}

void SplatRenderer::SetMap(const GaussianCloud& cloud) {
  cloud.Validate("Vulkan renderer map");
  const int n = cloud.size();
  // project.comp dispatches one invocation per Gaussian in x.
  const uint64_t max_groups = ctx_->properties().limits.maxComputeWorkGroupCount[0];
  DYPHO_CHECK_INPUT(static_cast<uint64_t>(n) <= max_groups * kProjectGroup)
      << "map has " << n << " Gaussians; this Vulkan device renders at most " << max_groups * kProjectGroup;
  vkDeviceWaitIdle(ctx_->device());
  DestroyMap();
  outputs_valid_ = false;
  n_ = n;
  sh_coeffs_ = cloud.sh_coeffs;
  const VkDeviceSize fsz = sizeof(float);
  means_ = ctx_->CreateBuffer(fsz * 3 * n, kUpload, false);
  log_scales_ = ctx_->CreateBuffer(fsz * 3 * n, kUpload, false);
  quats_ = ctx_->CreateBuffer(fsz * 4 * n, kUpload, false);
  logits_ = ctx_->CreateBuffer(fsz * n, kUpload, false);
  sh_ = ctx_->CreateBuffer(fsz * 3 * cloud.sh_coeffs * n, kUpload, false);
  splats_ = ctx_->CreateBuffer(fsz * 16 * n, kStorage, false);
  for (int k = 0; k < 2; ++k) {
    keys_[k] = ctx_->CreateBuffer(4 * VkDeviceSize(n), kStorage, false);
    values_[k] = ctx_->CreateBuffer(4 * VkDeviceSize(n), kStorage, false);
  }
  // splat.vert draws 6 vertices per Gaussian in one draw call.
  DYPHO_CHECK_INPUT(static_cast<uint64_t>(n) * 6 <= 0xffffffffull) << "map has too many Gaussians (" << n << ")";
  // Radix sort blocks: each sort thread owns `items` consecutive keys; at
  // most 2048 threads keep the histogram (256 x threads) small.
  sort_items_ = std::max<uint32_t>(256, (static_cast<uint32_t>(n) + 2047) / 2048);
  sort_threads_ = std::max<uint32_t>(1, (static_cast<uint32_t>(n) + sort_items_ - 1) / sort_items_);
  hist_buf_ = ctx_->CreateBuffer(4 * 256 * VkDeviceSize(sort_threads_), kStorage, false);

  // Quad indices 4k + {0, 1, 2, 2, 1, 3} when the device can address 4n
  // vertices in an indexed draw; otherwise 6 vertices per quad, unindexed.
  std::vector<uint32_t> quad_indices;
  if (n > 0 && uint64_t(4) * n - 1 <= ctx_->properties().limits.maxDrawIndexedIndexValue) {
    quad_indices.resize(size_t(6) * n);
    for (uint32_t k = 0; k < uint32_t(n); ++k) {
      const uint32_t v = 4 * k;
      const uint32_t tri[6] = {v, v + 1, v + 2, v + 2, v + 1, v + 3};
      std::memcpy(&quad_indices[size_t(6) * k], tri, sizeof(tri));
    }
    indices_ = ctx_->CreateBuffer(4 * quad_indices.size(),
                                  VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, false);
  }
  if (n > 0) {
    struct Upload {
      const std::vector<float>* data;
      Buffer* dst;
    };
    const Upload uploads[5] = {{&cloud.means, &means_},
                               {&cloud.log_scales, &log_scales_},
                               {&cloud.quats, &quats_},
                               {&cloud.opacity_logits, &logits_},
                               {&cloud.sh, &sh_}};
    const Upload index_upload{nullptr, &indices_};
    for (int i = 0; i < 6; ++i) {
      const Upload& u = i < 5 ? uploads[i] : index_upload;
      if (i == 5 && quad_indices.empty()) break;
      const VkDeviceSize bytes = i < 5 ? fsz * u.data->size() : 4 * quad_indices.size();
      const void* src = i < 5 ? static_cast<const void*>(u.data->data()) : quad_indices.data();
      Buffer staging = ctx_->CreateBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
      std::memcpy(staging.mapped, src, bytes);
      VkCommandBuffer cmd = ctx_->BeginOneShot();
      VkBufferCopy region{0, 0, bytes};
      vkCmdCopyBuffer(cmd, staging.buffer, u.dst->buffer, 1, &region);
      try {
        ctx_->SubmitAndWait(cmd);
      } catch (...) {
        ctx_->Destroy(&staging);
        throw;
      }
      ctx_->Destroy(&staging);
    }
  }
  WriteDescriptors();
}

void SplatRenderer::WriteDescriptors() {
  VkDevice d = ctx_->device();
  const VkDescriptorType SB = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  WriteBuffer(d, project_set_, 0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, camera_ubo_);
  const Buffer* proj[9] = {&means_, &log_scales_, &quats_, &logits_, &sh_, &splats_, &keys_[0], &values_[0], &stats_};
  for (int i = 0; i < 9; ++i) WriteBuffer(d, project_set_, i + 1, SB, *proj[i]);
  for (int k = 0; k < 2; ++k) {
    WriteBuffer(d, hist_sets_[k], 0, SB, keys_[k]);
    WriteBuffer(d, hist_sets_[k], 1, SB, hist_buf_);
    WriteBuffer(d, scatter_sets_[k], 0, SB, keys_[k]);
    WriteBuffer(d, scatter_sets_[k], 1, SB, values_[k]);
    WriteBuffer(d, scatter_sets_[k], 2, SB, keys_[1 - k]);
    WriteBuffer(d, scatter_sets_[k], 3, SB, values_[1 - k]);
    WriteBuffer(d, scatter_sets_[k], 4, SB, hist_buf_);
  }
  WriteBuffer(d, scan_set_, 0, SB, hist_buf_);
  WriteBuffer(d, args_set_, 0, SB, stats_);
  for (int k = 0; k < 2; ++k) {
    WriteBuffer(d, draw_sets_[k], 0, SB, splats_);
    WriteBuffer(d, draw_sets_[k], 1, SB, values_[k]);
  }
}

void SplatRenderer::Validate(const kernels::RasterCamera& camera, const kernels::RasterSettings& settings) const {
  kernels::ValidateRasterInputs(n_, sh_coeffs_, true, camera, settings);
  const auto& lim = ctx_->properties().limits;
  const uint32_t max_w = std::min(lim.maxImageDimension2D, lim.maxFramebufferWidth);
  const uint32_t max_h = std::min(lim.maxImageDimension2D, lim.maxFramebufferHeight);
  DYPHO_CHECK_INPUT(static_cast<uint32_t>(camera.width) <= max_w && static_cast<uint32_t>(camera.height) <= max_h)
      << "image size " << camera.width << "x" << camera.height << " exceeds this Vulkan device's limit " << max_w << "x"
      << max_h;
  DYPHO_CHECK_INPUT(static_cast<uint64_t>(camera.width) * camera.height * 5 * sizeof(float) <= (uint64_t(1) << 31))
      << "image size " << camera.width << "x" << camera.height << " is too large for one Vulkan render";
}

void SplatRenderer::EnsureTargets(uint32_t width, uint32_t height) {
  if (width == width_ && height == height_) return;
  vkDeviceWaitIdle(ctx_->device());
  DestroyTargets();
  const VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT;
  acc0_ = ctx_->CreateImage(width, height, kAccFormat, usage);
  acc1_ = ctx_->CreateImage(width, height, kAccFormat, usage);
  out_ = ctx_->CreateBuffer(VkDeviceSize(width) * height * 5 * sizeof(float), kStorage, true);
  VkImageView views[2] = {acc0_.view, acc1_.view};
  VkFramebufferCreateInfo fb{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
  fb.renderPass = render_pass_;
  fb.attachmentCount = 2;
  fb.pAttachments = views;
  fb.width = width;
  fb.height = height;
  fb.layers = 1;
  DYPHO_VK(vkCreateFramebuffer(ctx_->device(), &fb, nullptr, &framebuffer_));
  width_ = width;
  height_ = height;
  VkDevice d = ctx_->device();
  WriteStorageImage(d, resolve_set_, 0, acc0_.view);
  WriteStorageImage(d, resolve_set_, 1, acc1_.view);
  WriteBuffer(d, resolve_set_, 2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, out_);
  bound_display_ = VK_NULL_HANDLE;
}

void SplatRenderer::EnsureDisplayBinding(const Image* display) {
  const VkImageView view = display ? display->view : dummy_display_.view;
  if (view == bound_display_) return;
  WriteStorageImage(ctx_->device(), resolve_set_, 3, view);
  bound_display_ = view;
}

void SplatRenderer::Record(VkCommandBuffer cmd, const kernels::RasterCamera& camera,
                           const kernels::RasterSettings& settings, const SplatDrawOptions& draw,
                           const Image* display) {
  Validate(camera, settings);
  const uint32_t W = static_cast<uint32_t>(camera.width), H = static_cast<uint32_t>(camera.height);
  if (display) {
    DYPHO_CHECK(display->width == W && display->height == H) << "display image size differs from the camera";
  }
  EnsureTargets(W, H);
  EnsureDisplayBinding(display);
  const bool oit = settings.mode == kernels::CompositeMode::kOrderIndependent;

  // Camera constants, computed exactly as the CPU backend does.
  const auto cam = kernels::math::MakeCameraData<float>(camera, settings, sh_coeffs_);
  CameraBlock block{};
  for (int r = 0; r < 3; ++r) {
    float* row = r == 0 ? block.rot0 : (r == 1 ? block.rot1 : block.rot2);
    for (int c = 0; c < 3; ++c) row[c] = cam.R[c][r];
    row[3] = cam.t[r];
  }
  for (int k = 0; k < 3; ++k) block.center[k] = cam.center[k];
  block.intrinsics[0] = cam.fx;
  block.intrinsics[1] = cam.fy;
  block.intrinsics[2] = cam.cx;
  block.intrinsics[3] = cam.cy;
  block.limits[0] = cam.limits.x_neg;
  block.limits[1] = cam.limits.x_pos;
  block.limits[2] = cam.limits.y_neg;
  block.limits[3] = cam.limits.y_pos;
  block.planes[0] = cam.near_plane;
  block.planes[1] = cam.far_plane;
  block.planes[2] = cam.low_pass;
  block.size[0] = camera.width;
  block.size[1] = camera.height;
  block.size[2] = n_;
  block.size[3] = sh_coeffs_;
  block.options[0] = cam.sh_degree;
  block.options[1] = oit ? 1 : 0;
  std::memcpy(camera_ubo_.mapped, &block, sizeof(block));

  const VkPipelineStageFlags CS = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT;
  const VkAccessFlags RW = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
  auto stamp = [&](uint32_t k) {
    if (timestamps_) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps_, k);
  };
  if (timestamps_) vkCmdResetQueryPool(cmd, timestamps_, 0, 5);
  stamp(0);
  vkCmdFillBuffer(cmd, stats_.buffer, 0, VK_WHOLE_SIZE, 0);
  StageBarrier(cmd, VK_ACCESS_TRANSFER_WRITE_BIT, RW, VK_PIPELINE_STAGE_TRANSFER_BIT, CS);

  const uint32_t n = static_cast<uint32_t>(n_);
  if (n > 0) {
    // 1. Projection.
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, project_);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, project_pl_, 0, 1, &project_set_, 0, nullptr);
    vkCmdDispatch(cmd, (n + kProjectGroup - 1) / kProjectGroup, 1, 1);
    StageBarrier(cmd, VK_ACCESS_SHADER_WRITE_BIT, RW, CS, CS);
    stamp(1);

    // 2. Stable LSD radix sort, ping-ponging between buffers 0 and 1: in
    // sorted mode of the depth keys, 4 x 8 bits (ends in buffer 0); in OIT
    // mode one pass on the visible/culled key (ends in buffer 1), which
    // keeps index order. Either way the visible Gaussians come first.
    const uint32_t passes = oit ? 1 : 4;
    {
      for (uint32_t pass = 0; pass < passes; ++pass) {
        const uint32_t src = pass % 2;
        const SortPush push{n, 8 * pass, sort_items_, sort_threads_};
        const uint32_t groups = (sort_threads_ + kSortGroup - 1) / kSortGroup;
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, hist_);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, hist_pl_, 0, 1, &hist_sets_[src], 0, nullptr);
        vkCmdPushConstants(cmd, hist_pl_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
        vkCmdDispatch(cmd, groups, 1, 1);
        StageBarrier(cmd, VK_ACCESS_SHADER_WRITE_BIT, RW, CS, CS);
        const ScanPush scan{256 * sort_threads_};
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, scan_);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, scan_pl_, 0, 1, &scan_set_, 0, nullptr);
        vkCmdPushConstants(cmd, scan_pl_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(scan), &scan);
        vkCmdDispatch(cmd, 1, 1, 1);
        StageBarrier(cmd, VK_ACCESS_SHADER_WRITE_BIT, RW, CS, CS);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, scatter_);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, scatter_pl_, 0, 1, &scatter_sets_[src], 0,
                                nullptr);
        vkCmdPushConstants(cmd, scatter_pl_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
        vkCmdDispatch(cmd, groups, 1, 1);
        StageBarrier(cmd, VK_ACCESS_SHADER_WRITE_BIT, RW, CS, CS);
      }
    }
    // Draw only the visible ones (indirect arguments from their count).
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, args_);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, args_pl_, 0, 1, &args_set_, 0, nullptr);
    vkCmdDispatch(cmd, 1, 1, 1);
    StageBarrier(cmd, VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT, CS,
                 VK_PIPELINE_STAGE_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT);
  } else {
    stamp(1);
  }
  stamp(2);

  // 3. Splats into the accumulation targets.
  VkClearValue clears[2];
  clears[0].color = {{0.0f, 0.0f, 0.0f, oit ? 0.0f : 1.0f}};
  clears[1].color = {{0.0f, 0.0f, 0.0f, 1.0f}};
  VkRenderPassBeginInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  rp.renderPass = render_pass_;
  rp.framebuffer = framebuffer_;
  rp.renderArea = {{0, 0}, {W, H}};
  rp.clearValueCount = 2;
  rp.pClearValues = clears;
  vkCmdBeginRenderPass(cmd, &rp, VK_SUBPASS_CONTENTS_INLINE);
  if (n > 0) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, oit ? draw_oit_ : draw_sorted_);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, draw_pl_, 0, 1, &draw_sets_[oit ? 1 : 0], 0, nullptr);
    VkViewport viewport{0.0f, 0.0f, float(W), float(H), 0.0f, 1.0f};
    VkRect2D scissor{{0, 0}, {W, H}};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    const bool indexed = indices_.buffer != VK_NULL_HANDLE;
    DrawPush push{{float(W), float(H), 0.0f, 0.0f},
                  1u,
                  draw.points ? 1u : 0u,
                  draw.point_radius,
                  oit ? 1u : 0u,
                  indexed ? 4u : 6u};
    vkCmdPushConstants(cmd, draw_pl_, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push),
                       &push);
    if (indexed) {
      vkCmdBindIndexBuffer(cmd, indices_.buffer, 0, VK_INDEX_TYPE_UINT32);
      vkCmdDrawIndexedIndirect(cmd, draw_args_.buffer, 0, 1, 0);  // quads in drawing order (splat.vert)
    } else {
      vkCmdDrawIndirect(cmd, draw_args_.buffer, 5 * sizeof(uint32_t), 1, 0);
    }
  }
  vkCmdEndRenderPass(cmd);
  stamp(3);

  // 4. Resolve.
  if (display) {
    TransitionImage(cmd, display->image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL, 0,
                    VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, CS);
  }
  ResolvePush push{{settings.background[0], settings.background[1], settings.background[2], 0.0f},
                   W,
                   H,
                   oit ? 1u : 0u,
                   display ? 1u : 0u};
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolve_);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolve_pl_, 0, 1, &resolve_set_, 0, nullptr);
  vkCmdPushConstants(cmd, resolve_pl_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  vkCmdDispatch(cmd, (W + 15) / 16, (H + 15) / 16, 1);
  StageBarrier(cmd, VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT, CS, VK_PIPELINE_STAGE_HOST_BIT);
  stamp(4);
  outputs_valid_ = true;
  last_width_ = W;
  last_height_ = H;
}

void SplatRenderer::ReadOutputs(float* color, float* depth, float* alpha, kernels::RasterStats* stats) const {
  DYPHO_CHECK(outputs_valid_ && out_.mapped) << "ReadOutputs before Record";
  const size_t pixels = size_t(last_width_) * last_height_;
  const float* data = static_cast<const float*>(out_.mapped);
  if (color) std::memcpy(color, data, sizeof(float) * 3 * pixels);
  if (depth) std::memcpy(depth, data + 3 * pixels, sizeof(float) * pixels);
  if (alpha) std::memcpy(alpha, data + 4 * pixels, sizeof(float) * pixels);
  if (stats) {
    const uint32_t* s = static_cast<const uint32_t*>(stats_.mapped);
    *stats = kernels::RasterStats{};
    stats->num_gaussians = n_;
    stats->num_visible = static_cast<int>(s[0]);
    stats->num_nonfinite = static_cast<int>(s[1]);
  }
}

StageTimes SplatRenderer::ReadStageTimes() const {
  StageTimes t;
  if (!timestamps_ || !outputs_valid_) return t;
  uint64_t q[5];
  if (vkGetQueryPoolResults(ctx_->device(), timestamps_, 0, 5, sizeof(q), q, sizeof(uint64_t),
                            VK_QUERY_RESULT_64_BIT) != VK_SUCCESS) {
    return t;
  }
  const double ms = ctx_->properties().limits.timestampPeriod * 1e-6;
  t.project = (q[1] - q[0]) * ms;
  t.sort = (q[2] - q[1]) * ms;
  t.draw = (q[3] - q[2]) * ms;
  t.resolve = (q[4] - q[3]) * ms;
  return t;
}

}  // namespace dypho::vulkan
