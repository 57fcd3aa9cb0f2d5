// The mapper's keyframes (engine/map/mapper.h): their images at each
// resolution and the Gaussians a keyframe adds where the map does not explain
// it (Insert).
#include <cmath>
#include <vector>

#include <torch/torch.h>

#include "common/check.h"
#include "engine/map/image_sharpness.h"
#include "engine/map/sensor_model.h"
#include "engine/torch/mapper_impl.h"

namespace dypho {
namespace {

using torch::indexing::Slice;

}  // namespace

// The camera at 1/ds resolution.
Camera Mapper::Impl::CameraAt(int ds) const {
  Camera c = camera.Scaled(1.0 / ds);
  c.width = camera.width / ds;
  c.height = camera.height / ds;
  return c;
}

// Full-resolution colour [H, W, 3] uint8, depth [H, W] float [m] (0 =
// invalid) and dynamic mask [H, W] float (1 = dynamic) -> the images at
// 1/ds resolution.
Mapper::Impl::KeyframeImages Mapper::Impl::MakeImages(const torch::Tensor& rgb8, torch::Tensor depth,
                                                     torch::Tensor dynamic, int ds,
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
    im.sensor_homographies = ToDevice(torch::from_blob(hom.data(), {n, level.height, 3, 3}, HostFloat()));
  }
  return im;
}

// The keyframe's images at 1/ds resolution (the training ones, or made
// from the compact full-resolution copy).
Mapper::Impl::KeyframeImages Mapper::Impl::ImagesAt(const Keyframe& kf, int ds) const {
  if (ds == opt.train_downscale || !kf.rgb8.defined()) return kf.train;
  return MakeImages(kf.rgb8, kf.depth_half.to(torch::kFloat32), kf.dynamic8.to(torch::kFloat32), ds,
                    kf.angular_velocity);
}

Mapper::Impl::Keyframe Mapper::Impl::MakeKeyframe(const KeyframeInput& in) const {
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
  // The caller's images, copied to the mapper's device once.
  const torch::Tensor rgb8 = ToDevice(torch::from_blob(const_cast<uint8_t*>(in.rgb.data()), {h, w, 3}, torch::kUInt8));
  torch::Tensor depth = in.depth.empty()
                            ? torch::zeros({h, w}, Float())
                            : ToDevice(torch::from_blob(const_cast<float*>(in.depth.data()), {h, w}, HostFloat()));
  depth = torch::nan_to_num(depth, 0.0, 0.0, 0.0);
  const torch::Tensor dynamic8 =
      in.dynamic_mask.empty()
          ? torch::zeros({h, w}, Options(torch::kUInt8))
          : (torch::from_blob(const_cast<uint8_t*>(in.dynamic_mask.data()), {h, w}, torch::kUInt8) > 0)
                .to(Options(torch::kUInt8));
  kf.train = MakeImages(rgb8, depth, dynamic8.to(torch::kFloat32), opt.train_downscale, in.angular_velocity);
  if (RefineDownscale() != opt.train_downscale) {
    kf.rgb8 = rgb8;  // a copy already
    kf.depth_half = depth.to(torch::kHalf);
    kf.dynamic8 = dynamic8.clone();
  }
  kf.twist.Init(torch::zeros({1, 6}, Float()), 1.0f);
  kf.exposure.Init(torch::zeros({1, 6}, Float()), opt.lr_exposure);
  return kf;
}

int Mapper::Impl::Insert(const Keyframe& kf, int id, const std::vector<KeyframeFeature>& features) {
  torch::NoGradGuard no_grad;
  const KeyframeImages& im = kf.train;
  const int64_t h = train_camera.height, w = train_camera.width;
  torch::Tensor unexplained = torch::ones({h, w}, Options(torch::kBool));
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
  torch::Tensor grid = torch::zeros({h, w}, Options(torch::kBool));
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
  if (!features.empty()) {
    // Read on the host (copies when the map is on a GPU).
    const torch::Tensor candidates_host = candidates.to(torch::kCPU), rgb_host = im.rgb.to(torch::kCPU);
    auto unexplained_acc = candidates_host.accessor<bool, 2>();
    auto rgb_acc = rgb_host.accessor<float, 3>();
    for (const KeyframeFeature& f : features) {
      if (!(f.depth >= opt.min_depth && f.depth <= opt.max_depth) || !std::isfinite(f.x) || !std::isfinite(f.y))
        continue;
      const int x = static_cast<int>(std::lround((f.x + 0.5) / ds - 0.5));
      const int y = static_cast<int>(std::lround((f.y + 0.5) / ds - 0.5));
      if (x < 0 || y < 0 || x >= w || y >= h || !unexplained_acc[y][x]) continue;
      if (x % s == s / 2 && y % s == s / 2) continue;  // the grid already has it
      feat.insert(feat.end(), {static_cast<float>(x), static_cast<float>(y), f.depth, rgb_acc[y][x][0],
                               rgb_acc[y][x][1], rgb_acc[y][x][2]});
    }
  }
  torch::Tensor u = xs, v = ys;
  if (!feat.empty()) {
    const torch::Tensor ft =
        ToDevice(torch::from_blob(feat.data(), {static_cast<int64_t>(feat.size() / 6), 6}, HostFloat()));
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
  // Column-major = R^T.
  const torch::Tensor rt = ToDevice(torch::from_blob(const_cast<float*>(r.data()), {3, 3}, HostFloat()));
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
  AppendGaussians(world, ls, q, op, dc, rest, torch::full({m}, static_cast<int64_t>(id), Options(torch::kInt64)));
  return static_cast<int>(m);
}

}  // namespace dypho
