// Scenes, cameras and losses shared by the LibTorch rasterizer tests
// (torch_rasterize_test.cc on the CPU, torch_cuda_test.cc on CUDA tensors).
#pragma once

#include <cstdint>
#include <vector>

#include <torch/torch.h>

#include "common/rigid3.h"
#include "engine/torch/rasterize.h"
#include "kernels/rasterizer.h"

namespace dypho::torch_testing {

using kernels::RasterCamera;
using kernels::RasterSettings;

struct Scene {
  torch::Tensor means, log_scales, quats, opacity_logits, sh;

  std::vector<torch::Tensor> All() const { return {means, log_scales, quats, opacity_logits, sh}; }
  void RequireGrad() {
    for (torch::Tensor* t : {&means, &log_scales, &quats, &opacity_logits, &sh}) t->requires_grad_(true);
  }
};

inline RasterCamera MakeCamera(int width, int height, double focal) {
  RasterCamera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = focal;
  cam.cx = 0.5 * (width - 1);
  cam.cy = 0.5 * (height - 1);
  return cam;
}

inline void SetPose(const Rigid3d& cam_from_world, RasterCamera* cam) {
  const Eigen::Matrix<double, 3, 4> m = cam_from_world.ToMatrix();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) cam->cam_from_world[4 * r + c] = m(r, c);
  }
}

inline Rigid3d GetPose(const RasterCamera& cam) {
  Eigen::Matrix<double, 3, 4> m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = cam.cam_from_world[4 * r + c];
  }
  return Rigid3d::FromMatrix(m);
}

inline Eigen::Matrix<double, 6, 1> Twist(double a, double b, double c, double d, double e, double f) {
  Eigen::Matrix<double, 6, 1> xi;
  xi << a, b, c, d, e, f;
  return xi;
}

// N Gaussians in front of an identity camera, spread over the image: pixel
// (u, v) uniform, depth in [z_min, z_max]; sizes in world units.
inline Scene RandomScene(int64_t n, int64_t k, const RasterCamera& cam, uint64_t seed, torch::Dtype dtype,
                  double z_min = 2.0, double z_max = 4.0, double scale_min = 0.05, double scale_max = 0.2,
                  double logit_min = -0.5, double logit_max = 2.0) {
  torch::manual_seed(seed);
  auto d = torch::TensorOptions().dtype(torch::kFloat64);
  const torch::Tensor u = torch::rand({n}, d) * cam.width - 0.5;
  const torch::Tensor v = torch::rand({n}, d) * cam.height - 0.5;
  const torch::Tensor z = z_min + torch::rand({n}, d) * (z_max - z_min);
  Scene s;
  s.means = torch::stack({(u - cam.cx) * z / cam.fx, (v - cam.cy) * z / cam.fy, z}, 1);
  s.log_scales = torch::log(scale_min + torch::rand({n, 3}, d) * (scale_max - scale_min));
  s.quats = torch::randn({n, 4}, d);
  s.opacity_logits = logit_min + torch::rand({n}, d) * (logit_max - logit_min);
  s.sh = torch::randn({n, k, 3}, d) * 0.3;
  s.sh.select(1, 0).uniform_(-1.5, 1.5);
  for (torch::Tensor* t : {&s.means, &s.log_scales, &s.quats, &s.opacity_logits, &s.sh}) *t = t->to(dtype);
  return s;
}

inline Scene CloneScene(const Scene& s) {
  return Scene{s.means.detach().clone(), s.log_scales.detach().clone(), s.quats.detach().clone(),
               s.opacity_logits.detach().clone(), s.sh.detach().clone()};
}

inline RasterizeResult Render(const Scene& s, const torch::Tensor& twist, const RasterCamera& cam,
                       const RasterSettings& settings, const torch::Tensor& probe = torch::Tensor()) {
  return RasterizeGaussians(s.means, s.log_scales, s.quats, s.opacity_logits, s.sh, twist, cam, settings, probe);
}

struct LossWeights {
  torch::Tensor color, depth, alpha;
};

inline LossWeights RandomWeights(const RasterCamera& cam, torch::Dtype dtype, uint64_t seed) {
  torch::manual_seed(seed);
  auto o = torch::TensorOptions().dtype(dtype);
  return {torch::randn({cam.height, cam.width, 3}, o), torch::randn({cam.height, cam.width}, o),
          torch::randn({cam.height, cam.width}, o)};
}

inline torch::Tensor WeightedLoss(const RasterizeResult& r, const LossWeights& w) {
  return (w.color * r.color).sum() + (w.depth * r.depth).sum() + (w.alpha * r.alpha).sum();
}

}  // namespace dypho::torch_testing
