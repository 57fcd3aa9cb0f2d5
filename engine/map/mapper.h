// The Gaussian mapper: turns posed RGB-D keyframes (with dynamic masks) into a
// static 3D Gaussian map by masked colour+depth optimisation.
//
// The map's parameters live in LibTorch tensors inside the implementation
// (engine/torch/mapper.cc); this header has no LibTorch or OpenCV types.
//
// Per keyframe (AddKeyframe):
//  1. The current map is rendered at the keyframe's pose (at the training
//     resolution). Pixels that are static (mask 0), have a valid depth, and
//     are not explained by the map - rendered alpha below `insert_alpha`, or
//     observed depth in front of the rendered surface by more than
//     `insert_depth_ratio` of the observed depth - are candidates.
//  2. Candidates on a grid of `insert_stride` pixels become Gaussians: mean =
//     the unprojected pixel, isotropic standard deviation
//     `insert_scale_factor` * stride * depth / f (the footprint of a grid
//     cell), colour from the pixel (SH degree 0, higher orders zero), opacity
//     `insert_opacity`. With `insert_without_depth`, unexplained static pixels
//     without a depth reading get Gaussians too, at the frame's median depth
//     (the colour loss then shapes them; the depth loss ignores them). Tracker features with depth add one Gaussian each
//     (footprint of one pixel) where no grid Gaussian is added.
//  3. Each new Gaussian is anchored to the keyframe: when the keyframe's pose
//     is corrected later (SetKeyframePose), its Gaussians move rigidly with it.
//
// Optimisation (Optimize): Adam with per-parameter learning rates on
//   loss = (1 - lambda) L1(colour) + lambda (1 - SSIM(colour)) + w_depth L1(depth)
// where L1 and SSIM are averaged over static pixels only (dynamic pixels
// contribute nothing) and the depth term over static pixels with a valid
// depth (rendered depth = sum of weight * camera z, so unexplained pixels are
// pulled towards full coverage). SSIM is the standard 11x11, sigma 1.5
// Gaussian-window SSIM (Wang et al. 2004) with zero padding. Each iteration
// renders one keyframe: with probability `older_keyframe_prob` a random
// keyframe outside the window of the `window_size` newest ones, otherwise one
// of the window. Every `densify_every` iterations Gaussians whose mean
// screen-space gradient magnitude exceeds `densify_grad_threshold` are cloned
// (small ones) or split in two (large ones) as in Kerbl et al. 2023, and
// Gaussians with opacity below `prune_opacity` or a standard deviation above
// `prune_max_scale` are removed. With `refine_poses`, keyframe poses other than
// the first are refined through the rasterizer's pose gradient
// (KeyframeGivenPose keeps the pose as given; engine/map/trajectory_follow.h
// moves the frames between keyframes with them).
//
// Threading: a Mapper is not thread-safe by itself; the embedding API
// (engine/api.h) serialises access. Rendering and optimisation use
// `num_threads` CPU threads (rasterizer and LibTorch).
//
// Device: with `device` "cuda" (or "cuda:N") every tensor of the map lives on
// that GPU (Gaussians and their Adam state, keyframe images, pose and
// exposure parameters) and the rasterizer runs its CUDA backend; a keyframe's
// images are copied to the GPU once, in AddKeyframe, and Cloud(),
// KeyframePose() and the other accessors copy what they return to the host.
// Render() renders on the GPU too. The constructor throws InvalidInput naming
// mapper.device when the build cannot run there (a CPU-only LibTorch, no
// device, no CUDA rasterizer). Results on the GPU follow the CPU's within
// float rounding, not bit for bit (engine/torch/mapper_cuda_test.cc).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <array>

#include "engine/map/sensor_model.h"
#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/gaussians.h"
#include "engine/render/render.h"
#include "kernels/rasterizer.h"

namespace dypho {

struct MapperOptions {
  // Resolution and model.
  int train_downscale = 2;          // keyframes are optimised at 1/train_downscale resolution
  // Resolution of the steps over all keyframes (OptimizeAll: the final
  // refinement), 1/refine_downscale; 0 = train_downscale. Coarse to fine:
  // mapping at 1/2, the final refinement at full resolution.
  int refine_downscale = 0;
  int sh_degree = 1;                // SH degree of the map (0..3)
  float background = 0.0f;          // background grey level of renders [0, 1]
  // Insertion.
  int insert_stride = 2;            // grid step of new Gaussians [training px]
  float insert_alpha = 0.6f;        // rendered alpha below which a pixel is unexplained
  float insert_depth_ratio = 0.1f;  // observed depth this fraction in front of the render: unexplained
  float insert_scale_factor = 0.7f; // initial std = factor * stride * depth / f
  float insert_opacity = 0.7f;      // initial opacity (0, 1)
  bool insert_without_depth = true; // static pixels without depth get Gaussians at the frame's median depth
  float min_depth = 0.1f;           // [m] depths outside [min_depth, max_depth] are invalid
  float max_depth = 8.0f;           // [m]
  // Loss.
  float lambda_ssim = 0.2f;         // weight of (1 - SSIM) in the colour term
  float depth_weight = 0.5f;        // weight of the depth L1 term [1/m]
  // Keyframe window.
  int window_size = 8;              // newest keyframes sampled by default
  float older_keyframe_prob = 0.3f; // probability to train on a random older keyframe
  // Steps over all keyframes (the final refinement) draw a keyframe with a
  // weight of its sharpness (variance of the Laplacian) over the median
  // keyframe's, clamped to [sharp_sampling_floor, 1]: blurred keyframes of
  // fast rotation count less (1 = uniform).
  float sharp_sampling_floor = 1.0f;
  // Learning rates (Adam). Position rates are in metres per step.
  float lr_means = 2e-4f;
  float lr_log_scales = 5e-3f;
  float lr_quats = 1e-3f;
  float lr_opacity = 5e-2f;
  float lr_sh_dc = 2.5e-3f;
  float lr_sh_rest = 1.25e-4f;
  float lr_pose_rotation = 2e-4f;     // [rad per step], with refine_poses
  float lr_pose_translation = 2e-4f;  // [m per step], with refine_poses
  bool refine_poses = false;
  // Rolling shutter and motion blur of the camera (engine/map/sensor_model.h):
  // with it active, keyframes with an angular velocity are compared with the
  // render passed through the model. Default off (global shutter, no blur).
  SensorModel sensor;
  // Per-keyframe colour response (auto exposure and white balance of
  // consumer RGB-D cameras): the loss compares exp(g) * render + b per
  // channel with the keyframe, g and b learnt per keyframe; their mean over
  // the keyframes is kept at zero, so the map's colours are those of the
  // average exposure (what a viewer shows).
  bool refine_exposure = false;
  float lr_exposure = 5e-3f;  // per step, for g [log gain] and b [colour units]
  // Densification and pruning.
  int densify_every = 150;               // iterations; 0 = never
  // Mean |dL/d mean2d| in normalised device coordinates (pixels x width / 2
  // at the training resolution, as Kerbl et al. 2023 state theirs, 2e-4 for
  // 30k steps); 1e-3 densifies the top few percent of Gaussians on
  // tum_fr1_rpy_head250 (the gradient's 90th percentile is 5e-4 there).
  float densify_grad_threshold = 1e-3f;
  float densify_size_threshold = 0.02f;  // [m] std below which a Gaussian is cloned, else split
  int max_gaussians = 400000;            // densification stops at this count
  float prune_opacity = 0.01f;
  float prune_max_scale = 0.5f;          // [m] largest std kept
  // Compute.
  int num_threads = 0;               // 0 = all hardware threads
  uint64_t seed = 1;                 // keyframe sampling and splitting
  std::string device = "cpu";        // where the map is optimised and rendered: cpu, cuda or cuda:N (GPU N)
  // Throws InvalidInput naming the field.
  void Validate() const;
};

// True for the device names MapperOptions::device takes: "cpu", "cuda" (=
// "cuda:0"), "cuda:N" (N in 0..99, no leading zero).
bool IsMapperDevice(const std::string& device);

// A 2D feature of a keyframe (from the tracker) with its depth reading.
// Per-channel affine colour response: observed = gain * rendered + bias.
struct ColorResponse {
  std::array<float, 3> gain{1.0f, 1.0f, 1.0f};
  std::array<float, 3> bias{0.0f, 0.0f, 0.0f};
  void Apply(ImageF* rgb) const;  // 3 channels
};

// A frame aligned to the map (Mapper::AlignFrame).
struct FrameAlignment {
  Rigid3d cam_from_world;  // the refined pose
  ColorResponse response;  // the frame's colour response
  double loss_before = 0.0, loss_after = 0.0;  // the mapping loss at the start and at the end
};

struct KeyframeFeature {
  float x = 0.0f, y = 0.0f;  // undistorted pixel [px, full resolution]
  float depth = 0.0f;        // [m]; 0 = no reading (ignored)
};

struct KeyframeInput {
  double timestamp = 0.0;     // [s]
  ImageU8 rgb;                // RGB, 3 channels, camera size, undistorted (ideal pinhole)
  ImageF depth;               // [m], camera size; 0 or non-finite = invalid; may be empty (no depth)
  ImageU8 dynamic_mask;       // 1 channel, camera size, non-zero = dynamic; empty = all static
  Rigid3d cam_from_world;     // the keyframe's pose
  std::vector<KeyframeFeature> features;
  // [rad/s] the camera's rotation rate at the frame (the model of
  // engine/map/sensor_model.h); used with MapperOptions::sensor. Zero = still.
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  // The rectified right image (RGB) while the dense depth of the pair is
  // still to be computed (the engine does it before mapping:
  // FrameBuffers::keyframe_depth_from_pair; `depth` is then a preview).
  // The mapper itself takes keyframes with this empty.
  ImageU8 right_rgb;
};

struct MapperStats {
  int iterations = 0;           // total so far
  int num_gaussians = 0;
  int num_keyframes = 0;
  double last_loss = 0.0;       // loss of the latest iteration
  double mean_loss = 0.0;       // mean over the latest Optimize call
  int added = 0;                // Gaussians inserted (total)
  int densified = 0;            // Gaussians added by clone/split (total)
  int pruned = 0;               // Gaussians removed (total)
  int carved = 0;               // Gaussians removed by CarveFreeSpace (total)
  double optimize_seconds = 0;  // wall time in Optimize (total)
  double insert_seconds = 0;    // wall time in AddKeyframe (total)
};

class Mapper {
 public:
  // `camera` is the ideal pinhole camera of the undistorted images; its
  // distortion must be zero. Throws InvalidInput for bad options or camera.
  Mapper(const Camera& camera, const MapperOptions& options = MapperOptions());
  ~Mapper();
  Mapper(const Mapper&) = delete;
  Mapper& operator=(const Mapper&) = delete;

  // Inserts a keyframe (see the top of this file) and returns its id
  // (0, 1, ...). Throws InvalidInput for wrong sizes or channel counts.
  int AddKeyframe(const KeyframeInput& keyframe);
  // Runs `iterations` optimisation steps over the keyframes. Returns the
  // stats after them. No keyframe yet: does nothing.
  MapperStats Optimize(int iterations);
  // Runs `iterations` steps drawing keyframes uniformly from all of them
  // (the final refinement after the last keyframe).
  MapperStats OptimizeAll(int iterations);
  // The loss averaged over every keyframe at the current map (no step);
  // NaN without keyframes or Gaussians.
  double MeanKeyframeLoss() const;

  // Removes what other keyframes see through: a Gaussian whose mean
  // projects, in at least `min_votes` keyframes other than its own, onto a
  // static pixel whose depth lies behind it (the nearest depth of the 3x3
  // neighbourhood farther than the mean by more than margin_abs + margin_rel
  // x its depth: the camera saw the space it occupies as empty), and in more
  // keyframes so than on a depth that agrees with it, is removed. This keeps
  // moving things the dynamic mask missed out of the map (a person seen in
  // one keyframe is seen through in the others) and removes floaters.
  // Returns the number removed.
  int CarveFreeSpace(int min_votes = 2, float margin_abs = 0.05f, float margin_rel = 0.05f);

  // A host system corrected keyframe `id`'s pose: the keyframe and the
  // Gaussians anchored to it move rigidly to the new pose.
  void SetKeyframePose(int id, const Rigid3d& cam_from_world);
  // Its pose now (refined, with refine_poses) and as it was given
  // (AddKeyframe or the last SetKeyframePose), before refinement.
  Rigid3d KeyframePose(int id) const;
  Rigid3d KeyframeGivenPose(int id) const;
  // The keyframe's colour response: frame = gain * render + bias per channel
  // (identity without refine_exposure).
  ColorResponse KeyframeColorResponse(int id) const;
  // Photometric alignment of a frame that is not a keyframe (same input as
  // AddKeyframe; its pose is the start) against the map, which does not
  // change: `iterations` steps on a pose twist and a colour response. Used to
  // score novel views of a map whose keyframe poses and exposures were
  // refined (the test-time pose optimisation of BARF, Lin et al. 2021).
  FrameAlignment AlignFrame(const KeyframeInput& frame, int iterations) const;
  double KeyframeTimestamp(int id) const;
  int num_keyframes() const;
  int num_gaussians() const;
  MapperStats stats() const;
  const Camera& camera() const;
  const MapperOptions& options() const;

  // The map as host arrays (a copy).
  GaussianCloud Cloud() const;
  // Replaces the map (e.g. loaded from a PLY); the Gaussians are anchored to
  // no keyframe. Throws InvalidInput for an inconsistent cloud.
  void SetCloud(const GaussianCloud& cloud);
  // Renders the map at any pose and intrinsics (no gradients). On a GPU
  // mapper it renders there and the stats hold num_gaussians and num_visible
  // only.
  RenderedView Render(const Camera& camera, const Rigid3d& cam_from_world,
                      kernels::CompositeMode mode = kernels::CompositeMode::kSorted) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho
