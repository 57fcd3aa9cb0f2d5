// The Gaussian mapper (engine/map/mapper.h) on LibTorch tensors.
#include "engine/map/mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include <torch/torch.h>

#include "common/check.h"
#include "common/logging.h"
#include "engine/map/keyframe_selector.h"
#include "engine/torch/adam.h"
#include "engine/torch/mapper_ops.h"
#include "engine/torch/rasterize.h"
#include "engine/torch/sensor_warp.h"
#include "engine/torch/threads.h"

namespace dypho {
namespace {

using torch::indexing::Slice;

constexpr float kShC0 = 0.28209479177387814f;

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

torch::TensorOptions Float() { return torch::TensorOptions().dtype(torch::kFloat32); }

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
  double sharpness = 0.0;  // ImageSharpness of the colour image (engine/map/keyframe_selector.h)
  KeyframeImages train;    // at the training resolution (train_downscale)
  // Full resolution, compact, to make the images at refine_downscale on
  // demand: uint8 [H, W, 3], half [H, W] [m], uint8 [H, W] (1 = dynamic).
  // Undefined when refine_downscale is the training resolution.
  torch::Tensor rgb8, depth_half, dynamic8;
  AdamParam twist;         // [1, 6] pose refinement (refine_poses)
  AdamParam exposure;      // [1, 6] log gain rgb, bias rgb (refine_exposure)
};

kernels::RasterCamera RasterCameraOf(const Camera& camera, const Rigid3d& cam_from_world) {
  return ToRasterCamera(camera, cam_from_world);
}

}  // namespace


struct Mapper::Impl {
  Camera camera;        // full resolution, ideal pinhole
  Camera train_camera;  // 1 / train_downscale
  MapperOptions opt;
  int sh_coeffs = 1;
  AdamParam means, log_scales, quats, opacity, sh_dc, sh_rest;
  torch::Tensor anchor;      // [N] int64 keyframe id, -1 = none
  torch::Tensor grad_accum;  // [N] summed |dL/d mean2d|
  torch::Tensor grad_count;  // [N] renders in which the Gaussian was visible
  std::vector<Keyframe> keyframes;
  torch::Tensor ssim_window = GaussianWindow1d();
  std::mt19937_64 rng;
  MapperStats stats;
  int since_densify = 0;

  kernels::RasterSettings Settings(kernels::CompositeMode mode = kernels::CompositeMode::kSorted) const {
    kernels::RasterSettings s;
    s.mode = mode;
    s.sh_degree = opt.sh_degree;
    for (float& b : s.background) b = opt.background;
    s.num_threads = opt.num_threads;
    return s;
  }

  int64_t size() const { return opacity.rows(); }

  torch::Tensor Sh() const {
    return sh_coeffs > 1 ? torch::cat({sh_dc.value, sh_rest.value}, 1) : sh_dc.value;
  }

  std::vector<AdamParam*> GaussianParams() { return {&means, &log_scales, &quats, &opacity, &sh_dc, &sh_rest}; }

  void InitEmpty() {
    means.Init(torch::zeros({0, 3}, Float()), opt.lr_means);
    log_scales.Init(torch::zeros({0, 3}, Float()), opt.lr_log_scales);
    quats.Init(torch::zeros({0, 4}, Float()), opt.lr_quats);
    opacity.Init(torch::zeros({0}, Float()), opt.lr_opacity);
    sh_dc.Init(torch::zeros({0, 1, 3}, Float()), opt.lr_sh_dc);
    sh_rest.Init(torch::zeros({0, sh_coeffs - 1, 3}, Float()), opt.lr_sh_rest);
    anchor = torch::zeros({0}, torch::kInt64);
    grad_accum = torch::zeros({0}, Float());
    grad_count = torch::zeros({0}, Float());
  }

  void AppendGaussians(const torch::Tensor& m, const torch::Tensor& ls, const torch::Tensor& q,
                       const torch::Tensor& op, const torch::Tensor& dc, const torch::Tensor& rest,
                       const torch::Tensor& anchors) {
    means.Append(m);
    log_scales.Append(ls);
    quats.Append(q);
    opacity.Append(op);
    sh_dc.Append(dc);
    sh_rest.Append(rest);
    anchor = torch::cat({anchor, anchors});
    grad_accum = torch::cat({grad_accum, torch::zeros({m.size(0)}, Float())});
    grad_count = torch::cat({grad_count, torch::zeros({m.size(0)}, Float())});
  }

  void SelectGaussians(const torch::Tensor& keep) {
    for (AdamParam* p : GaussianParams()) p->Select(keep);
    anchor = anchor.index({keep});
    grad_accum = grad_accum.index({keep});
    grad_count = grad_count.index({keep});
  }

  // The camera at 1/ds resolution.
  Camera CameraAt(int ds) const {
    Camera c = camera.Scaled(1.0 / ds);
    c.width = camera.width / ds;
    c.height = camera.height / ds;
    return c;
  }

  // Full-resolution colour [H, W, 3] uint8, depth [H, W] float [m] (0 =
  // invalid) and dynamic mask [H, W] float (1 = dynamic) -> the images at
  // 1/ds resolution.
  KeyframeImages MakeImages(const torch::Tensor& rgb8, torch::Tensor depth, torch::Tensor dynamic, int ds,
                            const Eigen::Vector3d& omega) const {
    namespace F = torch::nn::functional;
    const int64_t h = rgb8.size(0), w = rgb8.size(1);
    torch::Tensor rgb = rgb8.to(torch::kFloat32) / 255.0;
    torch::Tensor valid = ((depth >= opt.min_depth) & (depth <= opt.max_depth)).to(torch::kFloat32);
    depth = depth * valid;
    if (ds > 1) {
      const auto pool = F::AvgPool2dFuncOptions(ds).stride(ds);
      rgb = F::avg_pool2d(rgb.permute({2, 0, 1}).unsqueeze(0), pool).squeeze(0).permute({1, 2, 0});
      const torch::Tensor vsum = F::avg_pool2d(valid.view({1, 1, h, w}), pool).view({h / ds, w / ds});
      const torch::Tensor dsum = F::avg_pool2d(depth.view({1, 1, h, w}), pool).view({h / ds, w / ds});
      // A pixel has depth when at least 3/4 of its full-resolution pixels do
      // (the mean of those).
      valid = (vsum > 0.74).to(torch::kFloat32);
      depth = dsum / vsum.clamp_min(1e-6) * valid;
      dynamic = F::max_pool2d(dynamic.view({1, 1, h, w}), F::MaxPool2dFuncOptions(ds).stride(ds)).view({h / ds, w / ds});
    }
    KeyframeImages im;
    im.rgb = rgb.contiguous();
    im.depth = depth.contiguous();
    im.static_w = (1.0 - dynamic).contiguous();
    im.depth_w = (im.static_w * valid).contiguous();
    if (opt.sensor.active() && omega.norm() > 0) {
      const Camera level = CameraAt(ds);
      const int n = SensorSampleCount(level, omega, opt.sensor);
      std::vector<float> hom = SensorRowHomographies(level, omega, opt.sensor, n);
      im.sensor_homographies = torch::from_blob(hom.data(), {n, level.height, 3, 3}, Float()).clone();
    }
    return im;
  }

  // The keyframe's images at 1/ds resolution (the training ones, or made
  // from the compact full-resolution copy).
  KeyframeImages ImagesAt(const Keyframe& kf, int ds) const {
    if (ds == opt.train_downscale || !kf.rgb8.defined()) return kf.train;
    return MakeImages(kf.rgb8, kf.depth_half.to(torch::kFloat32), kf.dynamic8.to(torch::kFloat32), ds,
                      kf.angular_velocity);
  }

  int RefineDownscale() const { return opt.refine_downscale > 0 ? opt.refine_downscale : opt.train_downscale; }

  Keyframe MakeKeyframe(const KeyframeInput& in) const {
    const int w = camera.width, h = camera.height;
    DYPHO_CHECK_INPUT(in.rgb.width() == w && in.rgb.height() == h && in.rgb.channels() == 3)
        << "keyframe rgb must be " << w << "x" << h << "x3 (the mapper's camera), got " << in.rgb.width() << "x"
        << in.rgb.height() << "x" << in.rgb.channels();
    DYPHO_CHECK_INPUT(in.depth.empty() || (in.depth.width() == w && in.depth.height() == h && in.depth.channels() == 1))
        << "keyframe depth must be " << w << "x" << h << "x1, got " << in.depth.width() << "x" << in.depth.height()
        << "x" << in.depth.channels();
    DYPHO_CHECK_INPUT(in.dynamic_mask.empty() || (in.dynamic_mask.width() == w && in.dynamic_mask.height() == h &&
                                                  in.dynamic_mask.channels() == 1))
        << "keyframe dynamic_mask must be " << w << "x" << h << "x1, got " << in.dynamic_mask.width() << "x"
        << in.dynamic_mask.height() << "x" << in.dynamic_mask.channels();
    DYPHO_CHECK_INPUT(in.cam_from_world.translation.allFinite() && in.cam_from_world.rotation.coeffs().allFinite())
        << "keyframe cam_from_world is not finite";
    DYPHO_CHECK_INPUT(in.angular_velocity.allFinite()) << "keyframe angular_velocity must be finite";
    Keyframe kf;
    kf.timestamp = in.timestamp;
    kf.cam_from_world = in.cam_from_world;
    kf.angular_velocity = in.angular_velocity;
    kf.sharpness = ImageSharpness(in.rgb, in.dynamic_mask);
    const torch::Tensor rgb8 = torch::from_blob(const_cast<uint8_t*>(in.rgb.data()), {h, w, 3}, torch::kUInt8);
    torch::Tensor depth = in.depth.empty()
                              ? torch::zeros({h, w}, Float())
                              : torch::from_blob(const_cast<float*>(in.depth.data()), {h, w}, Float()).clone();
    depth = torch::nan_to_num(depth, 0.0, 0.0, 0.0);
    const torch::Tensor dynamic8 =
        in.dynamic_mask.empty()
            ? torch::zeros({h, w}, torch::kUInt8)
            : (torch::from_blob(const_cast<uint8_t*>(in.dynamic_mask.data()), {h, w}, torch::kUInt8) > 0)
                  .to(torch::kUInt8);
    kf.train = MakeImages(rgb8, depth, dynamic8.to(torch::kFloat32), opt.train_downscale, in.angular_velocity);
    if (RefineDownscale() != opt.train_downscale) {
      kf.rgb8 = rgb8.clone();
      kf.depth_half = depth.to(torch::kHalf);
      kf.dynamic8 = dynamic8.clone();
    }
    kf.twist.Init(torch::zeros({1, 6}, Float()), 1.0f);
    kf.exposure.Init(torch::zeros({1, 6}, Float()), opt.lr_exposure);
    return kf;
  }

  torch::Tensor TwistOf(const Keyframe& kf) const {
    return opt.refine_poses ? kf.twist.value.view({6}) : torch::Tensor();
  }

  // Renders keyframe k at 1/ds resolution (0 = the training resolution).
  RasterizeResult RenderKeyframe(const Keyframe& kf, const torch::Tensor& probe, bool with_twist, int ds = 0) {
    const Camera level = ds == 0 || ds == opt.train_downscale ? train_camera : CameraAt(ds);
    return RasterizeGaussians(means.value, log_scales.value, quats.value, opacity.value, Sh(),
                              with_twist ? TwistOf(kf) : torch::Tensor(), RasterCameraOf(level, kf.cam_from_world),
                              Settings(), probe);
  }

  int Insert(const Keyframe& kf, int id, const std::vector<KeyframeFeature>& features) {
    torch::NoGradGuard no_grad;
    const KeyframeImages& im = kf.train;
    const int64_t h = train_camera.height, w = train_camera.width;
    torch::Tensor unexplained = torch::ones({h, w}, torch::kBool);
    if (size() > 0) {
      const RasterizeResult r = RenderKeyframe(kf, torch::Tensor(), false);
      const torch::Tensor rendered_depth = r.depth / r.alpha.clamp_min(1e-6);
      unexplained = (r.alpha < opt.insert_alpha) |
                    (im.depth < rendered_depth * (1.0 - opt.insert_depth_ratio));
    }
    torch::Tensor candidates = unexplained & (im.depth_w > 0.5);
    // Static pixels without a depth reading (windows and screens in glare,
    // dark or shiny surfaces, beyond the sensor's range) still need colour.
    // They get the farthest depth read around them (the depth image grown
    // into its holes by repeated 3x3 maximum filters; the frame's largest
    // depth where that does not reach) and are then shaped by the colour
    // loss alone. The farthest neighbour, not a mean, so that they sit on or
    // behind the surfaces around them and never float in front of what other
    // views see.
    torch::Tensor fill_depth = im.depth;
    const torch::Tensor valid_depths = im.depth.index({im.depth_w > 0.5});
    if (opt.insert_without_depth && valid_depths.numel() > 0) {
      const torch::Tensor no_depth = unexplained & (im.static_w > 0.5) & (im.depth_w < 0.5);
      namespace F = torch::nn::functional;
      torch::Tensor grown = (im.depth * im.depth_w).view({1, 1, h, w});
      for (int i = 0; i < 24; ++i) {
        const torch::Tensor neighbours = F::max_pool2d(grown, F::MaxPool2dFuncOptions(3).stride(1).padding(1));
        grown = torch::where(grown > 0, grown, neighbours);
      }
      grown = grown.view({h, w});
      grown = torch::where(grown > 0, grown, valid_depths.max());
      fill_depth = torch::where(no_depth, grown, im.depth);
      candidates = candidates | no_depth;
    }
    // Grid subsampling.
    const int s = opt.insert_stride;
    torch::Tensor grid = torch::zeros({h, w}, torch::kBool);
    grid.index_put_({Slice(s / 2, torch::indexing::None, s), Slice(s / 2, torch::indexing::None, s)}, true);
    const torch::Tensor chosen = (candidates & grid).nonzero();  // [M, 2] (y, x)
    std::vector<float> fu, fv, fz, fscale;
    const torch::Tensor ys = chosen.select(1, 0).to(torch::kFloat32);
    const torch::Tensor xs = chosen.select(1, 1).to(torch::kFloat32);
    torch::Tensor z = fill_depth.index({chosen.select(1, 0), chosen.select(1, 1)});
    torch::Tensor colour = im.rgb.index({chosen.select(1, 0), chosen.select(1, 1)});  // [M, 3]
    torch::Tensor footprint = torch::full_like(z, static_cast<float>(s));
    // Tracker features (full-resolution pixels) on unexplained static pixels.
    std::vector<float> feat;  // x, y, z, r, g, b per feature
    const int ds = opt.train_downscale;
    auto unexplained_acc = candidates.accessor<bool, 2>();
    auto rgb_acc = im.rgb.accessor<float, 3>();
    for (const KeyframeFeature& f : features) {
      if (!(f.depth >= opt.min_depth && f.depth <= opt.max_depth) || !std::isfinite(f.x) || !std::isfinite(f.y)) continue;
      const int x = static_cast<int>(std::lround((f.x + 0.5) / ds - 0.5));
      const int y = static_cast<int>(std::lround((f.y + 0.5) / ds - 0.5));
      if (x < 0 || y < 0 || x >= w || y >= h || !unexplained_acc[y][x]) continue;
      if (x % s == s / 2 && y % s == s / 2) continue;  // the grid already has it
      feat.insert(feat.end(), {static_cast<float>(x), static_cast<float>(y), f.depth, rgb_acc[y][x][0],
                               rgb_acc[y][x][1], rgb_acc[y][x][2]});
    }
    torch::Tensor u = xs, v = ys;
    if (!feat.empty()) {
      const torch::Tensor ft = torch::from_blob(feat.data(), {static_cast<int64_t>(feat.size() / 6), 6}, Float()).clone();
      u = torch::cat({u, ft.select(1, 0)});
      v = torch::cat({v, ft.select(1, 1)});
      z = torch::cat({z, ft.select(1, 2)});
      colour = torch::cat({colour, ft.index({Slice(), Slice(3, 6)})});
      footprint = torch::cat({footprint, torch::ones({ft.size(0)}, Float())});
    }
    const int64_t m = z.size(0);
    if (m == 0) return 0;
    const double fx = train_camera.fx, fy = train_camera.fy;
    const torch::Tensor pc = torch::stack({(u - train_camera.cx) * z / fx, (v - train_camera.cy) * z / fy, z}, 1);
    const Rigid3d world_from_cam = kf.cam_from_world.Inverse();
    const Eigen::Matrix3f r = world_from_cam.rotation.toRotationMatrix().cast<float>();
    const Eigen::Vector3f t = world_from_cam.translation.cast<float>();
    const torch::Tensor rt = torch::from_blob(const_cast<float*>(r.data()), {3, 3}, Float()).clone();  // column-major = R^T
    const torch::Tensor tt = torch::tensor({t.x(), t.y(), t.z()}, Float());
    const torch::Tensor world = torch::matmul(pc, rt) + tt;
    const torch::Tensor sigma = opt.insert_scale_factor * footprint * z / static_cast<float>(0.5 * (fx + fy));
    const torch::Tensor ls = torch::log(sigma).unsqueeze(1).expand({m, 3}).contiguous();
    torch::Tensor q = torch::zeros({m, 4}, Float());
    q.select(1, 0).fill_(1.0);
    const float logit = std::log(opt.insert_opacity / (1.0f - opt.insert_opacity));
    const torch::Tensor op = torch::full({m}, logit, Float());
    const torch::Tensor dc = ((colour - 0.5f) / kShC0).view({m, 1, 3});
    const torch::Tensor rest = torch::zeros({m, sh_coeffs - 1, 3}, Float());
    AppendGaussians(world, ls, q, op, dc, rest, torch::full({m}, static_cast<int64_t>(id), torch::kInt64));
    return static_cast<int>(m);
  }

  // The render as the keyframe's sensor saw it (engine/map/sensor_model.h).
  static torch::Tensor SensorColor(const KeyframeImages& im, const torch::Tensor& color) {
    if (!im.sensor_homographies.defined()) return color;
    return SensorWarp(color, im.sensor_homographies);
  }

  torch::Tensor Loss(const Keyframe& kf, const KeyframeImages& im, const RasterizeResult& r, bool use_exposure) const {
    const torch::Tensor w = im.static_w;
    torch::Tensor color = SensorColor(im, r.color);
    if (use_exposure) {
      const torch::Tensor e = kf.exposure.value.view({6});
      color = color * e.slice(0, 0, 3).exp() + e.slice(0, 3, 6);
    }
    const double w_sum = std::max(1.0, w.sum().item<double>());
    const torch::Tensor l1 = ((color - im.rgb).abs() * w.unsqueeze(2)).sum() / (3.0 * w_sum);
    torch::Tensor loss = (1.0 - opt.lambda_ssim) * l1;
    if (opt.lambda_ssim > 0) {
      const torch::Tensor ssim = SsimMap(color.permute({2, 0, 1}), im.rgb.permute({2, 0, 1}), ssim_window);
      loss = loss + opt.lambda_ssim * (1.0 - (ssim * w.unsqueeze(0)).sum() / (3.0 * w_sum));
    }
    if (opt.depth_weight > 0) {
      const double d_sum = im.depth_w.sum().item<double>();
      if (d_sum > 0) loss = loss + opt.depth_weight * ((r.depth - im.depth).abs() * im.depth_w).sum() / d_sum;
    }
    return loss;
  }

  // One optimisation step on keyframe k at 1/ds resolution.
  double Step(int k, int ds) {
    Keyframe& kf = keyframes[k];
    const torch::Tensor probe = MakeMean2dAbsProbe(means.value);
    const bool refine = opt.refine_poses && k > 0;
    const KeyframeImages im = ImagesAt(kf, ds);
    const RasterizeResult r = RenderKeyframe(kf, probe, refine, ds);
    const torch::Tensor loss = Loss(kf, im, r, opt.refine_exposure);
    loss.backward();
    {
      torch::NoGradGuard no_grad;
      if (probe.grad().defined()) {
        // Densification thresholds are gradients per training pixel.
        const double to_train_px = static_cast<double>(opt.train_downscale) / ds;
        grad_accum.add_(to_train_px == 1.0 ? probe.grad() : probe.grad() * to_train_px);
        grad_count.add_((r.radii > 0).to(torch::kFloat32));
      }
    }
    const torch::Tensor visible = r.radii > 0;
    for (AdamParam* p : GaussianParams()) p->Step(visible);
    if (refine) StepTwist(kf);
    if (opt.refine_exposure) {
      // Every keyframe learns its response; the gauge is their mean (zero):
      // the map's colours are those of the average exposure, the best guess
      // for a frame whose exposure is unknown (a novel view in a viewer).
      torch::NoGradGuard no_grad;
      const torch::Tensor before = kf.exposure.value.detach().clone();
      kf.exposure.Step();
      const torch::Tensor shift = (kf.exposure.value - before) / static_cast<double>(keyframes.size());
      for (Keyframe& other : keyframes) other.exposure.value.sub_(shift);
    }
    if (kf.exposure.value.grad().defined()) kf.exposure.value.mutable_grad().reset();
    ++stats.iterations;
    ++since_densify;
    if (opt.densify_every > 0 && since_densify >= opt.densify_every) {
      DensifyAndPrune();
      since_densify = 0;
    }
    return loss.item<double>();
  }

  // Adam on the keyframe's pose twist with rates per component (rho, phi).
  void StepTwist(Keyframe& kf, float lr_scale = 1.0f) {
    const float t = opt.lr_pose_translation * lr_scale, r = opt.lr_pose_rotation * lr_scale;
    kf.twist.Step(torch::Tensor(), torch::tensor({t, t, t, r, r, r}, Float()).view({1, 6}));
  }

  void DensifyAndPrune() {
    torch::NoGradGuard no_grad;
    const int64_t n = size();
    if (n == 0) return;
    const torch::Tensor mean_grad = grad_accum / grad_count.clamp_min(1.0);
    const torch::Tensor max_scale = std::get<0>(log_scales.value.max(1)).exp();
    // In normalised device coordinates (x 2 / width) as Kerbl et al. 2023
    // give their threshold: the same value densifies alike at any resolution.
    const torch::Tensor mean_grad_ndc = mean_grad * (0.5 * train_camera.width);
    torch::Tensor densify = (mean_grad_ndc > opt.densify_grad_threshold) & (grad_count > 0);
    {
      const torch::Tensor seen = mean_grad_ndc.index({grad_count > 0});
      if (seen.numel() > 0) {
        const torch::Tensor q = torch::quantile(seen, torch::tensor({0.5f, 0.9f, 0.99f}, Float()));
        DYPHO_LOG(Debug) << "densify: mean |grad2d| median " << q[0].item<float>() << ", p90 " << q[1].item<float>()
                         << ", p99 " << q[2].item<float>() << "; over threshold: " << densify.sum().item<int64_t>();
      }
    }
    const int64_t budget = std::max<int64_t>(0, opt.max_gaussians - n);
    int64_t count = densify.sum().item<int64_t>();
    if (count > budget) {
      // Keep the largest gradients within the budget.
      const torch::Tensor scores = torch::where(densify, mean_grad_ndc, torch::full_like(mean_grad_ndc, -1.0f));
      densify = torch::zeros_like(densify);
      if (budget > 0) densify.index_put_({std::get<1>(scores.topk(budget))}, true);
      count = budget;
    }
    const torch::Tensor clone = densify & (max_scale <= opt.densify_size_threshold);
    const torch::Tensor split = densify & (max_scale > opt.densify_size_threshold);
    // Clones: copies with fresh optimiser state.
    const torch::Tensor ci = clone.nonzero().squeeze(1);
    const torch::Tensor si = split.nonzero().squeeze(1);
    std::vector<torch::Tensor> new_means, new_ls, new_q, new_op, new_dc, new_rest, new_anchor;
    auto take = [&](const torch::Tensor& idx) {
      new_ls.push_back(log_scales.value.index({idx}));
      new_q.push_back(quats.value.index({idx}));
      new_op.push_back(opacity.value.index({idx}));
      new_dc.push_back(sh_dc.value.index({idx}));
      new_rest.push_back(sh_rest.value.index({idx}));
      new_anchor.push_back(anchor.index({idx}));
    };
    if (ci.numel() > 0) {
      new_means.push_back(means.value.index({ci}));
      take(ci);
    }
    torch::Tensor keep = torch::ones({n}, torch::kBool);
    if (si.numel() > 0) {
      // Two samples from each split Gaussian, scales divided by 1.6 (Kerbl et al. 2023).
      const torch::Tensor rot = QuatToMatrix(quats.value.index({si}));
      const torch::Tensor scale = log_scales.value.index({si}).exp();
      for (int rep = 0; rep < 2; ++rep) {
        const torch::Tensor offset = torch::bmm(rot, (torch::randn(scale.sizes(), Float()) * scale).unsqueeze(2)).squeeze(2);
        new_means.push_back(means.value.index({si}) + offset);
        take(si);
        new_ls.back() = new_ls.back() - std::log(1.6f);
      }
      keep.index_put_({si}, false);
    }
    const int64_t added = ci.numel() + 2 * si.numel();
    // Prune: transparent or oversized.
    keep &= torch::sigmoid(opacity.value) >= opt.prune_opacity;
    keep &= max_scale <= opt.prune_max_scale;
    keep &= torch::isfinite(means.value).all(1) & torch::isfinite(log_scales.value).all(1);
    const int64_t removed = n - keep.sum().item<int64_t>();
    SelectGaussians(keep);
    if (!new_means.empty()) {
      AppendGaussians(torch::cat(new_means), torch::cat(new_ls), torch::cat(new_q), torch::cat(new_op),
                      torch::cat(new_dc), torch::cat(new_rest), torch::cat(new_anchor));
    }
    grad_accum.zero_();
    grad_count.zero_();
    stats.densified += static_cast<int>(added);
    stats.pruned += static_cast<int>(removed - si.numel());  // split originals are replaced, not pruned
  }

  int Carve(int min_votes, float margin_abs, float margin_rel) {
    torch::NoGradGuard no_grad;
    const int64_t n = size();
    if (n == 0 || keyframes.size() < 2) return 0;
    namespace F = torch::nn::functional;
    const torch::Tensor means_now = means.value.detach();
    torch::Tensor free_votes = torch::zeros({n}, torch::kInt32), seen_votes = torch::zeros({n}, torch::kInt32);
    const int64_t h = train_camera.height, w = train_camera.width;
    for (size_t k = 0; k < keyframes.size(); ++k) {
      const Keyframe& kf = keyframes[k];
      const Rigid3d pose = PoseOf(kf);
      const Eigen::Matrix3f r = pose.rotation.toRotationMatrix().cast<float>();
      const torch::Tensor rt = torch::from_blob(const_cast<float*>(r.data()), {3, 3}, Float()).clone();  // R^T
      const torch::Tensor t = torch::tensor({static_cast<float>(pose.translation.x()),
                                             static_cast<float>(pose.translation.y()),
                                             static_cast<float>(pose.translation.z())},
                                            Float());
      const torch::Tensor pc = torch::matmul(means_now, rt) + t;
      const torch::Tensor z = pc.select(1, 2);
      const torch::Tensor zs = z.clamp_min(1e-6);
      const torch::Tensor u = torch::round(train_camera.fx * pc.select(1, 0) / zs + train_camera.cx);
      const torch::Tensor v = torch::round(train_camera.fy * pc.select(1, 1) / zs + train_camera.cy);
      const torch::Tensor inside = (z > opt.min_depth) & (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1);
      const torch::Tensor idx = (v.clamp(0, h - 1) * w + u.clamp(0, w - 1)).to(torch::kInt64);
      // Nearest valid depth of each 3x3 neighbourhood (invalid = far away).
      const torch::Tensor depth = torch::where(kf.train.depth_w > 0.5, kf.train.depth, torch::full_like(kf.train.depth, 1e6));
      const torch::Tensor nearest =
          (-F::max_pool2d((-depth).view({1, 1, h, w}), F::MaxPool2dFuncOptions(3).stride(1).padding(1))).view({-1});
      const torch::Tensor d = nearest.index({idx});
      const torch::Tensor observed = inside & (d < 1e5);
      const torch::Tensor stat = kf.train.static_w.view({-1}).index({idx}) > 0.5;
      const torch::Tensor margin = margin_abs + margin_rel * z;
      const torch::Tensor own = anchor == static_cast<int64_t>(k);
      free_votes += (observed & stat & ~own & (d > z + margin)).to(torch::kInt32);
      const torch::Tensor centre = kf.train.depth.view({-1}).index({idx});
      seen_votes += (inside & ((centre - z).abs() < margin)).to(torch::kInt32);
    }
    const torch::Tensor remove = (free_votes >= min_votes) & (free_votes > seen_votes);
    const int removed = static_cast<int>(remove.sum().item<int64_t>());
    if (removed > 0) SelectGaussians(~remove);
    stats.carved += removed;
    stats.num_gaussians = static_cast<int>(size());
    return removed;
  }

  // Sampling weight of each keyframe in the steps over all keyframes: its
  // sharpness over the median sharpness, within [sharp_sampling_floor, 1]
  // (blurred keyframes are drawn less often; all 1 when off).
  std::vector<double> SamplingWeights() const {
    std::vector<double> w(keyframes.size(), 1.0);
    if (opt.sharp_sampling_floor >= 1.0f || keyframes.size() < 3) return w;
    std::vector<double> s;
    for (const Keyframe& kf : keyframes) s.push_back(kf.sharpness);
    std::nth_element(s.begin(), s.begin() + s.size() / 2, s.end());
    const double median = s[s.size() / 2];
    if (!(median > 0)) return w;
    for (size_t k = 0; k < keyframes.size(); ++k)
      w[k] = std::clamp(keyframes[k].sharpness / median, static_cast<double>(opt.sharp_sampling_floor), 1.0);
    return w;
  }

  int PickKeyframe(bool all) {
    const int n = static_cast<int>(keyframes.size());
    if (all) {
      const std::vector<double> w = SamplingWeights();
      return std::discrete_distribution<int>(w.begin(), w.end())(rng);
    }
    if (n <= opt.window_size) return std::uniform_int_distribution<int>(0, n - 1)(rng);
    const int window_begin = n - opt.window_size;
    if (std::uniform_real_distribution<float>(0, 1)(rng) < opt.older_keyframe_prob) {
      return std::uniform_int_distribution<int>(0, window_begin - 1)(rng);
    }
    return std::uniform_int_distribution<int>(window_begin, n - 1)(rng);
  }

  MapperStats Run(int iterations, bool all) {
    DYPHO_CHECK_INPUT(iterations >= 0) << "Mapper::Optimize: iterations must be >= 0 (got " << iterations << ")";
    if (keyframes.empty() || iterations == 0) return stats;
    const auto start = std::chrono::steady_clock::now();
    double sum = 0;
    for (int i = 0; i < iterations; ++i) {
      if (size() == 0) break;
      stats.last_loss = Step(PickKeyframe(all), all ? RefineDownscale() : opt.train_downscale);
      sum += stats.last_loss;
    }
    stats.mean_loss = sum / iterations;
    stats.optimize_seconds += Seconds(start);
    stats.num_gaussians = static_cast<int>(size());
    return stats;
  }

  double MeanLoss() {
    torch::NoGradGuard no_grad;
    if (keyframes.empty() || size() == 0) return std::nan("");
    double sum = 0;
    for (const Keyframe& kf : keyframes)
      sum += Loss(kf, kf.train, RenderKeyframe(kf, torch::Tensor(), true), opt.refine_exposure).item<double>();
    return sum / keyframes.size();
  }

  // A frame's pose and colour response against the frozen map: photometric
  // alignment of a pose twist and an exposure (log gain, bias) per channel.
  FrameAlignment Align(const KeyframeInput& in, int iterations) {
    Keyframe kf = MakeKeyframe(in);
    kf.exposure.Init(torch::zeros({1, 6}, Float()), 2e-2f);
    const torch::Tensor m = means.value.detach(), ls = log_scales.value.detach(), q = quats.value.detach(),
                        op = opacity.value.detach(), sh = Sh().detach();
    const kernels::RasterCamera cam = RasterCameraOf(train_camera, kf.cam_from_world);
    FrameAlignment out;
    for (int it = 0; it <= iterations; ++it) {
      const RasterizeResult r = RasterizeGaussians(m, ls, q, op, sh, kf.twist.value.view({6}), cam, Settings());
      const torch::Tensor loss = Loss(kf, kf.train, r, true);
      if (it == 0) out.loss_before = loss.item<double>();
      out.loss_after = loss.item<double>();
      if (it == iterations) break;
      loss.backward();
      StepTwist(kf, 2.5f);
      kf.exposure.Step();
    }
    const torch::Tensor t = kf.twist.value.detach().view({6}).to(torch::kFloat64).contiguous();
    Eigen::Matrix<double, 6, 1> xi;
    std::copy(t.data_ptr<double>(), t.data_ptr<double>() + 6, xi.data());
    out.cam_from_world = Rigid3d::Exp(xi) * kf.cam_from_world;
    const torch::Tensor e = kf.exposure.value.detach().view({6}).contiguous();
    for (int i = 0; i < 3; ++i) {
      out.response.gain[i] = std::exp(e[i].item<float>());
      out.response.bias[i] = e[i + 3].item<float>();
    }
    return out;
  }

  Rigid3d PoseOf(const Keyframe& kf) const {
    if (!opt.refine_poses) return kf.cam_from_world;
    const torch::Tensor t = kf.twist.value.detach().view({6}).to(torch::kFloat64).contiguous();
    Eigen::Matrix<double, 6, 1> xi;
    std::copy(t.data_ptr<double>(), t.data_ptr<double>() + 6, xi.data());
    return Rigid3d::Exp(xi) * kf.cam_from_world;
  }
};

Mapper::Mapper(const Camera& camera, const MapperOptions& options) : impl_(new Impl) {
  options.Validate();
  std::string error;
  DYPHO_CHECK_INPUT(camera.IsPlausibleCalibration(&error)) << "mapper camera: " << error;
  DYPHO_CHECK_INPUT(!camera.HasDistortion())
      << "mapper camera must be an ideal pinhole (undistort the images first; see engine/map/undistort.h)";
  DYPHO_CHECK_INPUT(camera.width >= 16 * options.train_downscale && camera.height >= 16 * options.train_downscale)
      << "mapper camera " << camera.width << "x" << camera.height << " is too small for train_downscale "
      << options.train_downscale;
  impl_->camera = camera;
  impl_->opt = options;
  impl_->train_camera = camera.Scaled(1.0 / options.train_downscale);
  impl_->train_camera.width = camera.width / options.train_downscale;
  impl_->train_camera.height = camera.height / options.train_downscale;
  impl_->sh_coeffs = (options.sh_degree + 1) * (options.sh_degree + 1);
  impl_->rng.seed(options.seed);
  torch::manual_seed(options.seed);
  ConfigureTorchThreads(options.num_threads);
  impl_->InitEmpty();
}

Mapper::~Mapper() = default;

int Mapper::AddKeyframe(const KeyframeInput& input) {
  const auto start = std::chrono::steady_clock::now();
  Keyframe kf = impl_->MakeKeyframe(input);
  const int id = static_cast<int>(impl_->keyframes.size());
  const int added = impl_->Insert(kf, id, input.features);
  impl_->keyframes.push_back(std::move(kf));
  impl_->stats.added += added;
  impl_->stats.num_keyframes = id + 1;
  impl_->stats.num_gaussians = static_cast<int>(impl_->size());
  impl_->stats.insert_seconds += Seconds(start);
  return id;
}

MapperStats Mapper::Optimize(int iterations) { return impl_->Run(iterations, false); }
double Mapper::MeanKeyframeLoss() const { return impl_->MeanLoss(); }
MapperStats Mapper::OptimizeAll(int iterations) { return impl_->Run(iterations, true); }

void Mapper::SetKeyframePose(int id, const Rigid3d& cam_from_world) {
  DYPHO_CHECK_INPUT(id >= 0 && id < num_keyframes())
      << "SetKeyframePose: no keyframe " << id << " (the map has " << num_keyframes() << ")";
  DYPHO_CHECK_INPUT(cam_from_world.translation.allFinite() && cam_from_world.rotation.coeffs().allFinite())
      << "SetKeyframePose: pose of keyframe " << id << " is not finite";
  Impl& m = *impl_;
  Keyframe& kf = m.keyframes[id];
  // World motion of everything anchored to the keyframe.
  const Rigid3d delta = cam_from_world.Inverse() * m.PoseOf(kf);
  kf.cam_from_world = cam_from_world;
  {
    torch::NoGradGuard no_grad;
    kf.twist.value.zero_();
    const torch::Tensor sel = (m.anchor == id).nonzero().squeeze(1);
    if (sel.numel() > 0) {
      const Eigen::Matrix3f r = delta.rotation.toRotationMatrix().cast<float>();
      const torch::Tensor rt = torch::from_blob(const_cast<float*>(r.data()), {3, 3}, Float()).clone();
      const torch::Tensor t = torch::tensor({static_cast<float>(delta.translation.x()),
                                             static_cast<float>(delta.translation.y()),
                                             static_cast<float>(delta.translation.z())},
                                            Float());
      m.means.value.index_put_({sel}, torch::matmul(m.means.value.index({sel}), rt) + t);
      const Eigen::Quaterniond q = delta.rotation;
      const torch::Tensor dq = torch::tensor({static_cast<float>(q.w()), static_cast<float>(q.x()),
                                              static_cast<float>(q.y()), static_cast<float>(q.z())},
                                             Float())
                                   .view({1, 4})
                                   .expand({sel.numel(), 4});
      m.quats.value.index_put_({sel}, QuatMultiply(dq, m.quats.value.index({sel})));
    }
  }
}

int Mapper::CarveFreeSpace(int min_votes, float margin_abs, float margin_rel) {
  DYPHO_CHECK_INPUT(min_votes >= 1) << "CarveFreeSpace: min_votes must be >= 1 (got " << min_votes << ")";
  DYPHO_CHECK_INPUT(std::isfinite(margin_abs) && margin_abs >= 0 && std::isfinite(margin_rel) && margin_rel >= 0)
      << "CarveFreeSpace: margins must be >= 0";
  return impl_->Carve(min_votes, margin_abs, margin_rel);
}

FrameAlignment Mapper::AlignFrame(const KeyframeInput& frame, int iterations) const {
  DYPHO_CHECK_INPUT(iterations >= 0) << "AlignFrame: iterations must be >= 0 (got " << iterations << ")";
  DYPHO_CHECK_INPUT(num_gaussians() > 0) << "AlignFrame: the map is empty";
  return impl_->Align(frame, iterations);
}

ColorResponse Mapper::KeyframeColorResponse(int id) const {
  DYPHO_CHECK_INPUT(id >= 0 && id < num_keyframes()) << "KeyframeColorResponse: no keyframe " << id;
  ColorResponse c;
  if (!impl_->opt.refine_exposure) return c;
  const torch::Tensor e = impl_->keyframes[id].exposure.value.detach().view({6}).contiguous();
  for (int i = 0; i < 3; ++i) {
    c.gain[i] = std::exp(e[i].item<float>());
    c.bias[i] = e[i + 3].item<float>();
  }
  return c;
}

void ColorResponse::Apply(ImageF* rgb) const {
  DYPHO_CHECK_INPUT(rgb && rgb->channels() == 3) << "ColorResponse::Apply needs a 3-channel image";
  float* p = rgb->data();
  for (size_t i = 0; i < rgb->size(); i += 3) {
    for (int c = 0; c < 3; ++c) p[i + c] = gain[c] * p[i + c] + bias[c];
  }
}

Rigid3d Mapper::KeyframePose(int id) const {
  DYPHO_CHECK_INPUT(id >= 0 && id < num_keyframes()) << "KeyframePose: no keyframe " << id;
  return impl_->PoseOf(impl_->keyframes[id]);
}

double Mapper::KeyframeTimestamp(int id) const {
  DYPHO_CHECK_INPUT(id >= 0 && id < num_keyframes()) << "KeyframeTimestamp: no keyframe " << id;
  return impl_->keyframes[id].timestamp;
}

int Mapper::num_keyframes() const { return static_cast<int>(impl_->keyframes.size()); }
int Mapper::num_gaussians() const { return static_cast<int>(impl_->size()); }
MapperStats Mapper::stats() const {
  MapperStats s = impl_->stats;
  s.num_gaussians = num_gaussians();
  s.num_keyframes = num_keyframes();
  return s;
}
const Camera& Mapper::camera() const { return impl_->camera; }
const MapperOptions& Mapper::options() const { return impl_->opt; }

GaussianCloud Mapper::Cloud() const {
  torch::NoGradGuard no_grad;
  const Impl& m = *impl_;
  GaussianCloud cloud;
  cloud.sh_coeffs = m.sh_coeffs;
  auto copy = [](const torch::Tensor& t, std::vector<float>& out) {
    const torch::Tensor c = t.detach().to(torch::kFloat32).contiguous();
    out.assign(c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
  };
  copy(m.means.value, cloud.means);
  copy(m.log_scales.value, cloud.log_scales);
  copy(m.quats.value, cloud.quats);
  copy(m.opacity.value, cloud.opacity_logits);
  copy(m.Sh(), cloud.sh);
  return cloud;
}

void Mapper::SetCloud(const GaussianCloud& cloud) {
  cloud.Validate("Mapper::SetCloud");
  torch::NoGradGuard no_grad;
  Impl& m = *impl_;
  const int64_t n = cloud.size();
  auto tensor = [](const std::vector<float>& v, std::vector<int64_t> shape) {
    return torch::from_blob(const_cast<float*>(v.data()), shape, Float()).clone();
  };
  torch::Tensor sh = tensor(cloud.sh, {n, cloud.sh_coeffs, 3});
  // Convert to the mapper's SH size: truncate or pad with zeros.
  if (cloud.sh_coeffs > m.sh_coeffs) {
    sh = sh.index({Slice(), Slice(0, m.sh_coeffs)}).contiguous();
  } else if (cloud.sh_coeffs < m.sh_coeffs) {
    sh = torch::cat({sh, torch::zeros({n, m.sh_coeffs - cloud.sh_coeffs, 3}, Float())}, 1);
  }
  m.InitEmpty();
  m.AppendGaussians(tensor(cloud.means, {n, 3}), tensor(cloud.log_scales, {n, 3}), tensor(cloud.quats, {n, 4}),
                    tensor(cloud.opacity_logits, {n}), sh.index({Slice(), Slice(0, 1)}).contiguous(),
                    sh.index({Slice(), Slice(1, torch::indexing::None)}).contiguous(),
                    torch::full({n}, static_cast<int64_t>(-1), torch::kInt64));
}

RenderedView Mapper::Render(const Camera& camera, const Rigid3d& cam_from_world, kernels::CompositeMode mode) const {
  return RenderView(Cloud(), camera, cam_from_world, impl_->Settings(mode));
}

}  // namespace dypho
