// The LibTorch autograd op on CUDA tensors (engine/torch/rasterize.h):
// gradients against central differences in double precision, and parity with
// the same op on CPU tensors (outputs and every gradient, both compositing
// modes, SH degrees 0..3). The mapping run on the GPU is the real Mapper's:
// engine/torch/mapper_cuda_test.cc.
//
// Every test is skipped, saying "no GPU", where LibTorch sees no CUDA device
// or the build has no CUDA backend. tools/gpu_check.sh counts such a skip as
// a failure on a machine with a GPU.
//
// float64 runs on the CPU backend only (rasterize.h), so the "gradcheck in
// double" compares the CUDA op's float32 gradients with central differences
// of the loss evaluated in double precision by the CPU reference: the
// differences are exact to ~1e-9, the CUDA gradients to float rounding.
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "common/rigid3.h"
#include "engine/torch/rasterize.h"
#include "engine/torch/torch_test_scene.h"
#include "kernels/rasterizer.h"

namespace dypho {
namespace {

using kernels::CompositeMode;
using kernels::RasterCamera;
using kernels::RasterSettings;
using namespace torch_testing;

#define DYPHO_REQUIRE_GPU()                                                                               \
  do {                                                                                                    \
    std::string why;                                                                                      \
    if (!torch::cuda::is_available()) GTEST_SKIP() << "no GPU: LibTorch sees no CUDA device";             \
    if (!kernels::BackendAvailable(kernels::Backend::kCuda, &why)) GTEST_SKIP() << "no GPU: " << why;     \
  } while (0)

const torch::Device kGpu(torch::kCUDA, 0);

Scene To(const Scene& s, torch::Device device, torch::Dtype dtype) {
  Scene out = CloneScene(s);
  for (torch::Tensor* t : {&out.means, &out.log_scales, &out.quats, &out.opacity_logits, &out.sh}) {
    *t = t->to(device, dtype);
  }
  return out;
}

class TorchCudaModes : public ::testing::TestWithParam<CompositeMode> {};

// CUDA float32 gradients of a weighted sum of colour, depth and alpha (all
// parameters and a non-zero pose twist) against central differences in
// double of the same loss (CPU reference).
TEST_P(TorchCudaModes, GradientsMatchDoubleCentralDifferences) {
  DYPHO_REQUIRE_GPU();
  const RasterCamera cam = MakeCamera(20, 16, 18.0);
  RasterSettings settings;
  settings.mode = GetParam();
  settings.sh_degree = 1;
  settings.background[1] = 0.5f;
  // Few, large, overlapping Gaussians keep the loss smooth (as in
  // torch_rasterize_test's double gradcheck).
  const Scene base = RandomScene(4, 4, cam, 11, torch::kFloat64, 2.0, 3.0, 0.2, 0.45, -0.5, 1.5);
  const std::vector<double> xi = {0.03, -0.02, 0.01, 0.02, -0.01, 0.025};
  const LossWeights w64 = RandomWeights(cam, torch::kFloat64, 12);

  Scene g = To(base, kGpu, torch::kFloat32);
  g.RequireGrad();
  torch::Tensor twist = torch::tensor(xi, torch::dtype(torch::kFloat32)).to(kGpu).requires_grad_(true);
  const RasterizeResult r = Render(g, twist, cam, settings);
  ASSERT_TRUE(r.color.is_cuda());
  const LossWeights wg{w64.color.to(kGpu, torch::kFloat32), w64.depth.to(kGpu, torch::kFloat32),
                       w64.alpha.to(kGpu, torch::kFloat32)};
  std::vector<torch::Tensor> inputs = g.All();
  inputs.push_back(twist);
  const std::vector<torch::Tensor> grads = torch::autograd::grad({WeightedLoss(r, wg)}, inputs);

  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> point = base.All();
  for (torch::Tensor& t : point) t = t.clone();
  point.push_back(torch::tensor(xi, torch::kFloat64));
  auto loss_at = [&](const std::vector<torch::Tensor>& x) {
    const Scene p{x[0], x[1], x[2], x[3], x[4]};
    return WeightedLoss(Render(p, x[5], cam, settings), w64).item<double>();
  };
  const double h = 1e-6;
  double max_rel = 0.0;
  int checked = 0;
  for (size_t t = 0; t < point.size(); ++t) {
    ASSERT_TRUE(grads[t].is_cuda()) << "gradient " << t;
    const torch::Tensor analytic = grads[t].cpu().to(torch::kFloat64).contiguous();
    double* x = point[t].data_ptr<double>();
    for (int64_t i = 0; i < point[t].numel(); ++i) {
      const double keep = x[i];
      x[i] = keep + h;
      const double fp = loss_at(point);
      x[i] = keep - h;
      const double fm = loss_at(point);
      x[i] = keep;
      const double numeric = (fp - fm) / (2 * h);
      const double a = analytic.data_ptr<double>()[i];
      // float32 accumulation over 320 pixels: ~1e-4 relative.
      EXPECT_NEAR(a, numeric, 2e-3 * (1.0 + std::abs(numeric))) << "input " << t << " entry " << i;
      max_rel = std::max(max_rel, std::abs(a - numeric) / (1.0 + std::abs(numeric)));
      ++checked;
    }
  }
  EXPECT_EQ(checked, 4 * (3 + 3 + 4 + 1 + 12) + 6);
  std::ostringstream text;
  text << std::scientific << max_rel;
  RecordProperty("max_rel_err", text.str());
  std::printf("[ gradcheck ] %s: max relative error CUDA vs double differences %s\n",
              kernels::CompositeModeName(settings.mode), text.str().c_str());
}

// The op on CUDA tensors and on CPU tensors: same images, radii, and every
// gradient (five parameters, twist, |dL/d mean2d| probe), SH degrees 0..3.
TEST_P(TorchCudaModes, CudaTensorsMatchCpuTensors) {
  DYPHO_REQUIRE_GPU();
  RasterCamera cam = MakeCamera(160, 120, 130.0);
  SetPose(Rigid3d::Exp(Twist(0.05, -0.03, 0.02, 0.02, -0.01, 0.03)), &cam);
  for (int degree = 0; degree <= 3; ++degree) {
    SCOPED_TRACE(::testing::Message() << "sh_degree " << degree);
    RasterSettings settings;
    settings.mode = GetParam();
    settings.sh_degree = degree;
    settings.background[2] = 0.4f;
    const int64_t k = (degree + 1) * (degree + 1);
    const Scene base = RandomScene(2000, k, cam, 80 + degree, torch::kFloat32, 1.5, 5.0, 0.01, 0.1);
    const LossWeights w = RandomWeights(cam, torch::kFloat32, 90 + degree);
    struct Out {
      RasterizeResult r;
      std::vector<torch::Tensor> grads;
    };
    auto run = [&](torch::Device device) {
      Scene s = To(base, device, torch::kFloat32);
      s.RequireGrad();
      torch::Tensor twist = torch::zeros({6}, torch::device(device).requires_grad(true));
      torch::Tensor probe = MakeMean2dAbsProbe(s.means);
      Out out;
      out.r = Render(s, twist, cam, settings, probe);
      WeightedLoss(out.r, {w.color.to(device), w.depth.to(device), w.alpha.to(device)}).backward();
      for (const torch::Tensor& t : s.All()) out.grads.push_back(t.grad().cpu());
      out.grads.push_back(twist.grad().cpu());
      out.grads.push_back(probe.grad().cpu());
      return out;
    };
    const Out cpu = run(torch::kCPU);
    const Out gpu = run(kGpu);
    ASSERT_TRUE(gpu.r.color.is_cuda());
    auto frac_over = [](const torch::Tensor& a, const torch::Tensor& b, double tol) {
      return (a - b).abs().gt(tol).to(torch::kFloat64).mean().item<double>();
    };
    // Same tolerances as tests/cuda_parity_test.cc: 1e-4 on all but 0.5 % of
    // the pixels, 5e-2 everywhere.
    for (auto [name, a, b] : {std::tuple{"color", cpu.r.color, gpu.r.color.cpu()},
                              std::tuple{"depth", cpu.r.depth, gpu.r.depth.cpu()},
                              std::tuple{"alpha", cpu.r.alpha, gpu.r.alpha.cpu()}}) {
      EXPECT_LE(frac_over(a, b, std::string(name) == "depth" ? 5e-4 : 1e-4), 0.005) << name;
      EXPECT_LT((a - b).abs().max().item<double>(), 5e-2) << name;
    }
    EXPECT_LE(cpu.r.radii.ne(gpu.r.radii.cpu()).sum().item<int64_t>(), 1 + 2000 / 100);
    const char* names[] = {"means", "log_scales", "quats", "opacity_logits", "sh", "twist", "mean2d_abs"};
    for (size_t i = 0; i < cpu.grads.size(); ++i) {
      const torch::Tensor a = cpu.grads[i].to(torch::kFloat64), b = gpu.grads[i].to(torch::kFloat64);
      const double rel_l2 = ((a - b).norm() / a.norm().clamp_min(1e-30)).item<double>();
      EXPECT_LT(rel_l2, i == 5 ? 2e-3 : 1e-3) << names[i];
      EXPECT_TRUE(torch::isfinite(b).all().item<bool>()) << names[i];
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Modes, TorchCudaModes,
                         ::testing::Values(CompositeMode::kSorted, CompositeMode::kOrderIndependent),
                         [](const ::testing::TestParamInfo<CompositeMode>& info) {
                           return info.param == CompositeMode::kSorted ? "Sorted" : "OrderIndependent";
                         });

}  // namespace
}  // namespace dypho
