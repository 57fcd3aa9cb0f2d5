// The Gaussian mapper (engine/map/mapper.h) on LibTorch tensors: the class
// glue, the loss and the optimisation steps (the stages are in
// mapper_insert.cc and mapper_densify.cc; the state in mapper_impl.h).
#include "engine/map/mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <string>

#include <torch/torch.h>

#include "common/check.h"
#include "common/logging.h"
#include "engine/torch/mapper_impl.h"
#include "engine/torch/sensor_warp.h"
#include "engine/torch/threads.h"

namespace dypho {
namespace {

using torch::indexing::Slice;

// The torch device of MapperOptions::device ("cpu", "cuda", "cuda:N"; the
// options were validated). Throws InvalidInput naming mapper.device, saying
// what is missing and how to build for it, when this build cannot map there.
torch::Device MapperDevice(const std::string& name) {
  if (name == "cpu") return torch::kCPU;
  const int index = name == "cuda" ? 0 : std::stoi(name.substr(5));
  const torch::Device device(torch::kCUDA, static_cast<c10::DeviceIndex>(index));
  const char* how =
      ". Map on the CPU (mapper.device=cpu), or build dypho against a CUDA LibTorch, with nvcc, on a machine with "
      "an NVIDIA GPU (README, \"Building with an NVIDIA GPU (CUDA)\")";
  DYPHO_CHECK_INPUT(at::hasCUDA()) << "mapper.device is '" << name
                                   << "', but the LibTorch this dypho was built with is a CPU-only build" << how;
  DYPHO_CHECK_INPUT(torch::cuda::is_available())
      << "mapper.device is '" << name
      << "', but LibTorch sees no CUDA device (no NVIDIA GPU, its driver missing or too old for this CUDA, or "
         "CUDA_VISIBLE_DEVICES hides it)"
      << how;
  const int64_t count = static_cast<int64_t>(torch::cuda::device_count());
  DYPHO_CHECK_INPUT(index < count)
      << "mapper.device is '" << name << "', but LibTorch sees " << count << " CUDA device(s): cuda:0 to cuda:"
      << count - 1;
  std::string why;
  DYPHO_CHECK_INPUT(kernels::BackendAvailable(kernels::Backend::kCuda, &why))
      << "mapper.device is '" << name << "', but the CUDA rasterizer is unavailable: " << why << how;
  return device;
}

}  // namespace

kernels::RasterSettings Mapper::Impl::Settings(kernels::CompositeMode mode) const {
  kernels::RasterSettings s;
  s.mode = mode;
  s.sh_degree = opt.sh_degree;
  for (float& b : s.background) b = opt.background;
  s.num_threads = opt.num_threads;
  return s;
}

torch::Tensor Mapper::Impl::Sh() const {
  return sh_coeffs > 1 ? torch::cat({sh_dc.value, sh_rest.value}, 1) : sh_dc.value;
}

void Mapper::Impl::InitEmpty() {
  means.Init(torch::zeros({0, 3}, Float()), opt.lr_means);
  log_scales.Init(torch::zeros({0, 3}, Float()), opt.lr_log_scales);
  quats.Init(torch::zeros({0, 4}, Float()), opt.lr_quats);
  opacity.Init(torch::zeros({0}, Float()), opt.lr_opacity);
  sh_dc.Init(torch::zeros({0, 1, 3}, Float()), opt.lr_sh_dc);
  sh_rest.Init(torch::zeros({0, sh_coeffs - 1, 3}, Float()), opt.lr_sh_rest);
  anchor = torch::zeros({0}, Options(torch::kInt64));
  grad_accum = torch::zeros({0}, Float());
  grad_count = torch::zeros({0}, Float());
}

void Mapper::Impl::AppendGaussians(const torch::Tensor& m, const torch::Tensor& ls, const torch::Tensor& q,
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

void Mapper::Impl::SelectGaussians(const torch::Tensor& keep) {
  for (AdamParam* p : GaussianParams()) p->Select(keep);
  anchor = anchor.index({keep});
  grad_accum = grad_accum.index({keep});
  grad_count = grad_count.index({keep});
}

torch::Tensor Mapper::Impl::TwistOf(const Keyframe& kf) const {
  return opt.refine_poses ? kf.twist.value.view({6}) : torch::Tensor();
}

RasterizeResult Mapper::Impl::RenderKeyframe(const Keyframe& kf, const torch::Tensor& probe, bool with_twist, int ds) {
  const Camera level = ds == 0 || ds == opt.train_downscale ? train_camera : CameraAt(ds);
  return RasterizeGaussians(means.value, log_scales.value, quats.value, opacity.value, Sh(),
                            with_twist ? TwistOf(kf) : torch::Tensor(), RasterCameraOf(level, kf.cam_from_world),
                            Settings(), probe);
}

torch::Tensor Mapper::Impl::SensorColor(const KeyframeImages& im, const torch::Tensor& color) {
  if (!im.sensor_homographies.defined()) return color;
  return SensorWarp(color, im.sensor_homographies);
}

torch::Tensor Mapper::Impl::Loss(const Keyframe& kf, const KeyframeImages& im, const RasterizeResult& r,
                                 bool use_exposure) const {
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

double Mapper::Impl::Step(int k, int ds) {
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

void Mapper::Impl::StepTwist(Keyframe& kf, float lr_scale) {
  const float t = opt.lr_pose_translation * lr_scale, r = opt.lr_pose_rotation * lr_scale;
  kf.twist.Step(torch::Tensor(), torch::tensor({t, t, t, r, r, r}, Float()).view({1, 6}));
}

// Sampling weight of each keyframe in the steps over all keyframes: its
// sharpness over the median sharpness, within [sharp_sampling_floor, 1]
// (blurred keyframes are drawn less often; all 1 when off).
std::vector<double> Mapper::Impl::SamplingWeights() const {
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

int Mapper::Impl::PickKeyframe(bool all) {
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

MapperStats Mapper::Impl::Run(int iterations, bool all) {
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

double Mapper::Impl::MeanLoss() {
  torch::NoGradGuard no_grad;
  if (keyframes.empty() || size() == 0) return std::nan("");
  double sum = 0;
  for (const Keyframe& kf : keyframes)
    sum += Loss(kf, kf.train, RenderKeyframe(kf, torch::Tensor(), true), opt.refine_exposure).item<double>();
  return sum / keyframes.size();
}

// A frame's pose and colour response against the frozen map: photometric
// alignment of a pose twist and an exposure (log gain, bias) per channel.
FrameAlignment Mapper::Impl::Align(const KeyframeInput& in, int iterations) {
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
  const torch::Tensor t = kf.twist.value.detach().view({6}).to(torch::kCPU, torch::kFloat64).contiguous();
  Eigen::Matrix<double, 6, 1> xi;
  std::copy(t.data_ptr<double>(), t.data_ptr<double>() + 6, xi.data());
  out.cam_from_world = Rigid3d::Exp(xi) * kf.cam_from_world;
  const torch::Tensor e = kf.exposure.value.detach().view({6}).to(torch::kCPU).contiguous();
  for (int i = 0; i < 3; ++i) {
    out.response.gain[i] = std::exp(e[i].item<float>());
    out.response.bias[i] = e[i + 3].item<float>();
  }
  return out;
}

Rigid3d Mapper::Impl::PoseOf(const Keyframe& kf) const {
  if (!opt.refine_poses) return kf.cam_from_world;
  const torch::Tensor t = kf.twist.value.detach().view({6}).to(torch::kCPU, torch::kFloat64).contiguous();
  Eigen::Matrix<double, 6, 1> xi;
  std::copy(t.data_ptr<double>(), t.data_ptr<double>() + 6, xi.data());
  return Rigid3d::Exp(xi) * kf.cam_from_world;
}

Mapper::Mapper(const Camera& camera, const MapperOptions& options) : impl_(new Impl) {
  options.Validate();
  impl_->device = MapperDevice(options.device);
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
  impl_->ssim_window = GaussianWindow1d().to(impl_->device);
  impl_->InitEmpty();
  if (!impl_->device.is_cpu()) {
    DYPHO_LOG(Info) << "mapper: map optimised and rendered on " << impl_->device.str();
  }
}

Mapper::~Mapper() = default;

int Mapper::AddKeyframe(const KeyframeInput& input) {
  const auto start = std::chrono::steady_clock::now();
  Impl::Keyframe kf = impl_->MakeKeyframe(input);
  const int id = static_cast<int>(impl_->keyframes.size());
  const int added = impl_->Insert(kf, id, input.features);
  impl_->keyframes.push_back(std::move(kf));
  impl_->stats.added += added;
  impl_->stats.num_keyframes = id + 1;
  impl_->stats.num_gaussians = static_cast<int>(impl_->size());
  impl_->stats.insert_seconds += Impl::Seconds(start);
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
  Impl::Keyframe& kf = m.keyframes[id];
  // World motion of everything anchored to the keyframe.
  const Rigid3d delta = cam_from_world.Inverse() * m.PoseOf(kf);
  kf.cam_from_world = cam_from_world;
  {
    torch::NoGradGuard no_grad;
    kf.twist.value.zero_();
    const torch::Tensor sel = (m.anchor == id).nonzero().squeeze(1);
    if (sel.numel() > 0) {
      const Eigen::Matrix3f r = delta.rotation.toRotationMatrix().cast<float>();
      const torch::Tensor rt = m.ToDevice(torch::from_blob(const_cast<float*>(r.data()), {3, 3}, Impl::HostFloat()));
      const torch::Tensor t = torch::tensor({static_cast<float>(delta.translation.x()),
                                             static_cast<float>(delta.translation.y()),
                                             static_cast<float>(delta.translation.z())},
                                            m.Float());
      m.means.value.index_put_({sel}, torch::matmul(m.means.value.index({sel}), rt) + t);
      const Eigen::Quaterniond q = delta.rotation;
      const torch::Tensor dq = torch::tensor({static_cast<float>(q.w()), static_cast<float>(q.x()),
                                              static_cast<float>(q.y()), static_cast<float>(q.z())},
                                             m.Float())
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
  const torch::Tensor e = impl_->keyframes[id].exposure.value.detach().view({6}).to(torch::kCPU).contiguous();
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

Rigid3d Mapper::KeyframeGivenPose(int id) const {
  DYPHO_CHECK_INPUT(id >= 0 && id < num_keyframes()) << "KeyframeGivenPose: no keyframe " << id;
  return impl_->keyframes[id].cam_from_world;
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
    const torch::Tensor c = t.detach().to(torch::kCPU, torch::kFloat32).contiguous();
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
  auto tensor = [&m](const std::vector<float>& v, std::vector<int64_t> shape) {
    return m.ToDevice(torch::from_blob(const_cast<float*>(v.data()), shape, Impl::HostFloat()));
  };
  torch::Tensor sh = tensor(cloud.sh, {n, cloud.sh_coeffs, 3});
  // Convert to the mapper's SH size: truncate or pad with zeros.
  if (cloud.sh_coeffs > m.sh_coeffs) {
    sh = sh.index({Slice(), Slice(0, m.sh_coeffs)}).contiguous();
  } else if (cloud.sh_coeffs < m.sh_coeffs) {
    sh = torch::cat({sh, torch::zeros({n, m.sh_coeffs - cloud.sh_coeffs, 3}, m.Float())}, 1);
  }
  m.InitEmpty();
  m.AppendGaussians(tensor(cloud.means, {n, 3}), tensor(cloud.log_scales, {n, 3}), tensor(cloud.quats, {n, 4}),
                    tensor(cloud.opacity_logits, {n}), sh.index({Slice(), Slice(0, 1)}).contiguous(),
                    sh.index({Slice(), Slice(1, torch::indexing::None)}).contiguous(),
                    torch::full({n}, static_cast<int64_t>(-1), m.Options(torch::kInt64)));
}

RenderedView Mapper::Render(const Camera& camera, const Rigid3d& cam_from_world, kernels::CompositeMode mode) const {
  const Impl& m = *impl_;
  if (m.device.is_cpu()) return RenderView(Cloud(), camera, cam_from_world, m.Settings(mode));
  // On the GPU: the op on the map's tensors; the images are copied to the host.
  torch::NoGradGuard no_grad;
  const RasterizeResult r = RasterizeGaussians(m.means.value, m.log_scales.value, m.quats.value, m.opacity.value,
                                               m.Sh(), torch::Tensor(), ToRasterCamera(camera, cam_from_world),
                                               m.Settings(mode));
  RenderedView view;
  auto host = [&](const torch::Tensor& t, int channels) {
    const torch::Tensor c = t.to(torch::kCPU).contiguous();
    ImageF image(camera.width, camera.height, channels);
    std::copy(c.data_ptr<float>(), c.data_ptr<float>() + c.numel(), image.data());
    return image;
  };
  view.color = host(r.color, 3);
  view.depth = host(r.depth, 1);
  view.alpha = host(r.alpha, 1);
  view.stats.num_gaussians = static_cast<int>(m.size());
  view.stats.num_visible = static_cast<int>((r.radii > 0).sum().item<int64_t>());
  return view;
}

}  // namespace dypho
