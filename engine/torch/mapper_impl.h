// The mapper's state (Mapper::Impl of engine/map/mapper.h) on LibTorch
// tensors, shared by its stage files:
//   mapper.cc          the class glue, the loss, the optimisation steps
//   mapper_insert.cc   keyframes in: their images and the Gaussians they add
//   mapper_densify.cc  densification, pruning and free-space carving
// Private to engine/torch/.
#pragma once

#include <chrono>
#include <cstdint>
#include <random>
#include <vector>

#include <torch/torch.h>

#include "engine/map/mapper.h"
#include "engine/torch/adam.h"
#include "engine/torch/mapper_ops.h"
#include "engine/torch/rasterize.h"

namespace dypho {

struct Mapper::Impl {
  static constexpr float kShC0 = 0.28209479177387814f;
  // Tensors are made on `device` (MapperOptions::device). Host memory (the
  // caller's images, Eigen matrices, std::vector) is wrapped with from_blob
  // on the host and copied there with ToDevice.
  torch::TensorOptions Options(torch::ScalarType type) const {
    return torch::TensorOptions().dtype(type).device(device);
  }
  torch::TensorOptions Float() const { return Options(torch::kFloat32); }
  static torch::TensorOptions HostFloat() { return torch::TensorOptions().dtype(torch::kFloat32); }
  // A copy of `host` (e.g. a from_blob view) on the device, owning its memory.
  torch::Tensor ToDevice(const torch::Tensor& host) const {
    return host.to(host.options().device(device), /*non_blocking=*/false, /*copy=*/true);
  }
  static double Seconds(std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
  }
  static kernels::RasterCamera RasterCameraOf(const Camera& camera, const Rigid3d& cam_from_world) {
    return ToRasterCamera(camera, cam_from_world);
  }

  // A keyframe's images at one resolution, as the loss uses them.
  struct KeyframeImages {
    torch::Tensor rgb;       // [h, w, 3] in [0, 1]
    torch::Tensor depth;     // [h, w] [m], 0 = invalid
    torch::Tensor static_w;  // [h, w] 1 = static, 0 = dynamic
    torch::Tensor depth_w;   // [h, w] static and valid depth
    torch::Tensor sensor_homographies;  // [n, h, 3, 3] per sample and row (sensor model); undefined = none
  };

  struct Keyframe {
    double timestamp = 0.0;
    Rigid3d cam_from_world;  // pose without the refinement twist
    Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  // [rad/s]
    double sharpness = 0.0;  // ImageSharpness of the colour image (engine/map/image_sharpness.h)
    KeyframeImages train;    // at the training resolution (train_downscale)
    // Full resolution, compact, to make the images at refine_downscale on
    // demand: uint8 [H, W, 3], half [H, W] [m], uint8 [H, W] (1 = dynamic).
    // Undefined when refine_downscale is the training resolution.
    torch::Tensor rgb8, depth_half, dynamic8;
    AdamParam twist;         // [1, 6] pose refinement (refine_poses)
    AdamParam exposure;      // [1, 6] log gain rgb, bias rgb (refine_exposure)
  };

  torch::Device device = torch::kCPU;  // of every tensor below
  Camera camera;        // full resolution, ideal pinhole
  Camera train_camera;  // 1 / train_downscale
  MapperOptions opt;
  int sh_coeffs = 1;
  AdamParam means, log_scales, quats, opacity, sh_dc, sh_rest;
  torch::Tensor anchor;      // [N] int64 keyframe id, -1 = none
  torch::Tensor grad_accum;  // [N] summed |dL/d mean2d|
  torch::Tensor grad_count;  // [N] renders in which the Gaussian was visible
  std::vector<Keyframe> keyframes;
  torch::Tensor ssim_window;  // [11] SSIM window (GaussianWindow1d)
  std::mt19937_64 rng;
  MapperStats stats;
  int since_densify = 0;

  int64_t size() const { return opacity.rows(); }
  std::vector<AdamParam*> GaussianParams() { return {&means, &log_scales, &quats, &opacity, &sh_dc, &sh_rest}; }
  int RefineDownscale() const { return opt.refine_downscale > 0 ? opt.refine_downscale : opt.train_downscale; }

  // mapper.cc: the map's tensors, rendering, loss and steps.
  kernels::RasterSettings Settings(kernels::CompositeMode mode = kernels::CompositeMode::kSorted) const;
  torch::Tensor Sh() const;
  void InitEmpty();
  void AppendGaussians(const torch::Tensor& m, const torch::Tensor& ls, const torch::Tensor& q,
                       const torch::Tensor& op, const torch::Tensor& dc, const torch::Tensor& rest,
                       const torch::Tensor& anchors);
  void SelectGaussians(const torch::Tensor& keep);
  torch::Tensor TwistOf(const Keyframe& kf) const;
  // Renders keyframe k at 1/ds resolution (0 = the training resolution).
  RasterizeResult RenderKeyframe(const Keyframe& kf, const torch::Tensor& probe, bool with_twist, int ds = 0);
  // The render as the keyframe's sensor saw it (engine/map/sensor_model.h).
  static torch::Tensor SensorColor(const KeyframeImages& im, const torch::Tensor& color);
  torch::Tensor Loss(const Keyframe& kf, const KeyframeImages& im, const RasterizeResult& r, bool use_exposure) const;
  // One optimisation step on keyframe k at 1/ds resolution.
  double Step(int k, int ds);
  // Adam on the keyframe's pose twist with rates per component (rho, phi).
  void StepTwist(Keyframe& kf, float lr_scale = 1.0f);
  std::vector<double> SamplingWeights() const;
  int PickKeyframe(bool all);
  MapperStats Run(int iterations, bool all);
  double MeanLoss();
  FrameAlignment Align(const KeyframeInput& in, int iterations);
  Rigid3d PoseOf(const Keyframe& kf) const;

  // mapper_insert.cc: keyframe images and the insertion of Gaussians.
  Camera CameraAt(int ds) const;
  KeyframeImages MakeImages(const torch::Tensor& rgb8, torch::Tensor depth, torch::Tensor dynamic, int ds,
                            const Eigen::Vector3d& omega) const;
  KeyframeImages ImagesAt(const Keyframe& kf, int ds) const;
  Keyframe MakeKeyframe(const KeyframeInput& in) const;
  int Insert(const Keyframe& kf, int id, const std::vector<KeyframeFeature>& features);

  // mapper_densify.cc: densification, pruning, carving.
  void DensifyAndPrune();
  int Carve(int min_votes, float margin_abs, float margin_rel);
};

}  // namespace dypho
