// The LibTorch autograd front end of the rasterizer (engine/torch/rasterize.h):
// exact agreement with the kernels' own backward, finite differences in
// double precision (pose twist included), optimisation with torch::optim,
// the |dL/d mean2d| probe, bad input, the empty scene, thread configuration.
#include <cmath>
#include <functional>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "common/check.h"
#include "common/files.h"
#include "common/rigid3.h"
#include "engine/torch/rasterize.h"
#include "engine/torch/threads.h"
#include "engine/torch/torch_test_scene.h"
#include "kernels/rasterizer.h"

namespace dypho {
namespace {

using kernels::CompositeMode;
using kernels::RasterCamera;
using kernels::RasterSettings;

using namespace torch_testing;  // Scene, RandomScene, Render, WeightedLoss, ...

// Runs `fn`, expects dypho::InvalidInput whose message holds every string.
void ExpectInvalid(const std::function<void()>& fn, std::initializer_list<const char*> parts) {
  try {
    fn();
    ADD_FAILURE() << "no exception; expected InvalidInput mentioning " << *parts.begin();
  } catch (const InvalidInput& e) {
    for (const char* p : parts) EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type: " << e.what();
  }
}

// ---------------------------------------------------------------------------
// (1) The autograd Function gives exactly the kernels' own backward.

class TorchVsKernel : public ::testing::TestWithParam<CompositeMode> {};

TEST_P(TorchVsKernel, GradientsEqualKernelBackward) {
  RasterCamera cam = MakeCamera(64, 48, 55.0);
  SetPose(Rigid3d::Exp(Twist(0.05, -0.03, 0.1, 0.02, -0.04, 0.03)), &cam);
  RasterSettings settings;
  settings.mode = GetParam();
  settings.background[0] = 0.1f;
  settings.background[1] = 0.3f;
  settings.background[2] = 0.7f;
  settings.num_threads = 2;
  Scene s = RandomScene(60, 9, cam, 7, torch::kFloat32);
  // Opacity as [N, 1]: the gradient comes back in the same shape.
  s.opacity_logits = s.opacity_logits.reshape({-1, 1}).contiguous();
  s.RequireGrad();
  torch::Tensor twist = torch::zeros({6}, torch::requires_grad());
  torch::Tensor probe = MakeMean2dAbsProbe(s.means);
  const LossWeights w = RandomWeights(cam, torch::kFloat32, 8);

  const RasterizeResult r = Render(s, twist, cam, settings, probe);
  WeightedLoss(r, w).backward();

  // The kernels, called directly with the same inputs and cotangents.
  const int n = static_cast<int>(s.means.size(0));
  kernels::GaussianParams p;
  p.means = s.means.data_ptr<float>();
  p.log_scales = s.log_scales.data_ptr<float>();
  p.quats = s.quats.data_ptr<float>();
  p.opacity_logits = s.opacity_logits.data_ptr<float>();
  p.sh = s.sh.data_ptr<float>();
  p.num_gaussians = n;
  p.sh_coeffs = 9;
  auto f = torch::TensorOptions().dtype(torch::kFloat32);
  torch::Tensor color = torch::empty({48, 64, 3}, f), depth = torch::empty({48, 64}, f),
                alpha = torch::empty({48, 64}, f), radii = torch::empty({n}, torch::kInt32);
  auto rasterizer = kernels::CreateRasterizer(kernels::Backend::kCpu);
  auto state = rasterizer->Forward(p, cam, settings,
                                   {color.data_ptr<float>(), depth.data_ptr<float>(), alpha.data_ptr<float>(),
                                    radii.data_ptr<int32_t>()});
  torch::Tensor v_means = torch::empty({n, 3}, f), v_log_scales = torch::empty({n, 3}, f),
                v_quats = torch::empty({n, 4}, f), v_opacity = torch::empty({n}, f),
                v_sh = torch::empty({n, 9, 3}, f), v_twist = torch::empty({6}, f), v_abs = torch::empty({n}, f);
  rasterizer->Backward(*state, p, cam, settings,
                       {w.color.data_ptr<float>(), w.depth.data_ptr<float>(), w.alpha.data_ptr<float>()},
                       {v_means.data_ptr<float>(), v_log_scales.data_ptr<float>(), v_quats.data_ptr<float>(),
                        v_opacity.data_ptr<float>(), v_sh.data_ptr<float>(), v_twist.data_ptr<float>(),
                        v_abs.data_ptr<float>()});

  EXPECT_TRUE(torch::equal(r.color, color));
  EXPECT_TRUE(torch::equal(r.depth, depth));
  EXPECT_TRUE(torch::equal(r.alpha, alpha));
  EXPECT_TRUE(torch::equal(r.radii, radii));
  EXPECT_EQ(r.radii.scalar_type(), torch::kInt32);
  EXPECT_FALSE(r.radii.requires_grad());
  EXPECT_GT(radii.gt(0).sum().item<int64_t>(), n / 2);  // the scene is mostly visible

  EXPECT_TRUE(torch::equal(s.means.grad(), v_means));
  EXPECT_TRUE(torch::equal(s.log_scales.grad(), v_log_scales));
  EXPECT_TRUE(torch::equal(s.quats.grad(), v_quats));
  ASSERT_EQ(s.opacity_logits.grad().sizes(), s.opacity_logits.sizes());
  EXPECT_TRUE(torch::equal(s.opacity_logits.grad().reshape({n}), v_opacity));
  EXPECT_TRUE(torch::equal(s.sh.grad(), v_sh));
  EXPECT_TRUE(torch::equal(twist.grad(), v_twist));
  EXPECT_TRUE(torch::equal(probe.grad(), v_abs));
  EXPECT_GT(v_twist.abs().sum().item<float>(), 0.0f);
  EXPECT_GT(v_abs.sum().item<float>(), 0.0f);
}

INSTANTIATE_TEST_SUITE_P(Modes, TorchVsKernel,
                         ::testing::Values(CompositeMode::kSorted, CompositeMode::kOrderIndependent),
                         [](const ::testing::TestParamInfo<CompositeMode>& info) {
                           return info.param == CompositeMode::kSorted ? "Sorted" : "OrderIndependent";
                         });

TEST(TorchRasterize, OnlyRequestedGradientsAreComputed) {
  const RasterCamera cam = MakeCamera(32, 24, 30.0);
  Scene s = RandomScene(10, 1, cam, 3, torch::kFloat32);
  s.sh.requires_grad_(true);
  const RasterizeResult r = Render(s, torch::Tensor(), cam, RasterSettings());
  r.color.sum().backward();  // depth and alpha unused: null cotangents
  EXPECT_TRUE(s.sh.grad().defined());
  EXPECT_FALSE(s.means.grad().defined());
  // Colour grows with the DC coefficient wherever the Gaussian is seen.
  EXPECT_GT(s.sh.grad().sum().item<float>(), 0.0f);
}

TEST(TorchRasterize, NonContiguousInputsGiveTheSameImage) {
  const RasterCamera cam = MakeCamera(32, 24, 30.0);
  const Scene s = RandomScene(12, 4, cam, 5, torch::kFloat32);
  Scene strided = s;
  strided.means = s.means.t().contiguous().t();  // [N, 3] with strides (1, N)
  strided.sh = s.sh.transpose(1, 2).contiguous().transpose(1, 2);
  ASSERT_FALSE(strided.means.is_contiguous());
  const RasterizeResult a = Render(s, torch::Tensor(), cam, RasterSettings());
  const RasterizeResult b = Render(strided, torch::Tensor(), cam, RasterSettings());
  EXPECT_TRUE(torch::equal(a.color, b.color));
  EXPECT_TRUE(torch::equal(a.depth, b.depth));
}

// ---------------------------------------------------------------------------
// (2) Finite differences in double precision (float64 runs the double CPU
// reference), all parameters and a non-zero pose twist.

class TorchGradCheck : public ::testing::TestWithParam<CompositeMode> {};

TEST_P(TorchGradCheck, MatchesCentralDifferencesInDouble) {
  const RasterCamera cam = MakeCamera(20, 16, 18.0);
  RasterSettings settings;
  settings.mode = GetParam();
  settings.sh_degree = 1;
  settings.background[1] = 0.5f;
  settings.num_threads = 1;
  // Few, large, overlapping Gaussians; opacity below sigmoid(2) < 0.99 and
  // transmittance never below 1e-4 keep the loss smooth around the point.
  Scene s = RandomScene(4, 4, cam, 11, torch::kFloat64, 2.0, 3.0, 0.2, 0.45, -0.5, 1.5);
  s.RequireGrad();
  torch::Tensor twist =
      torch::tensor({0.03, -0.02, 0.01, 0.02, -0.01, 0.025}, torch::dtype(torch::kFloat64).requires_grad(true));
  const LossWeights w = RandomWeights(cam, torch::kFloat64, 12);

  std::vector<torch::Tensor> inputs = s.All();
  inputs.push_back(twist);
  const RasterizeResult r = Render(s, twist, cam, settings);
  ASSERT_EQ(r.color.scalar_type(), torch::kFloat64);
  ASSERT_EQ(r.radii.gt(0).sum().item<int64_t>(), 4);
  const std::vector<torch::Tensor> grads = torch::autograd::grad({WeightedLoss(r, w)}, inputs);

  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> point;
  for (const torch::Tensor& t : inputs) point.push_back(t.detach().clone());
  auto loss_at = [&](const std::vector<torch::Tensor>& x) {
    const Scene p{x[0], x[1], x[2], x[3], x[4]};
    return WeightedLoss(Render(p, x[5], cam, settings), w).item<double>();
  };
  const double h = 1e-6;
  double max_err = 0.0;
  int checked = 0;
  for (size_t t = 0; t < point.size(); ++t) {
    const torch::Tensor analytic = grads[t].contiguous();
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
      const double err = std::abs(a - numeric);
      max_err = std::max(max_err, err / (1.0 + std::abs(numeric)));
      EXPECT_NEAR(a, numeric, 2e-6 * (1.0 + std::abs(numeric))) << "input " << t << " entry " << i;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 4 * (3 + 3 + 4 + 1 + 12) + 6);
  std::ostringstream err_text;
  err_text << std::scientific << max_err;
  RecordProperty("max_rel_err", err_text.str());
}

INSTANTIATE_TEST_SUITE_P(Modes, TorchGradCheck,
                         ::testing::Values(CompositeMode::kSorted, CompositeMode::kOrderIndependent),
                         [](const ::testing::TestParamInfo<CompositeMode>& info) {
                           return info.param == CompositeMode::kSorted ? "Sorted" : "OrderIndependent";
                         });

TEST(TorchRasterize, DoubleAndFloatAgree) {
  const RasterCamera cam = MakeCamera(40, 30, 36.0);
  const Scene s64 = RandomScene(30, 4, cam, 21, torch::kFloat64);
  Scene s32;
  s32.means = s64.means.to(torch::kFloat32);
  s32.log_scales = s64.log_scales.to(torch::kFloat32);
  s32.quats = s64.quats.to(torch::kFloat32);
  s32.opacity_logits = s64.opacity_logits.to(torch::kFloat32);
  s32.sh = s64.sh.to(torch::kFloat32);
  const RasterizeResult a = Render(s64, torch::Tensor(), cam, RasterSettings());
  const RasterizeResult b = Render(s32, torch::Tensor(), cam, RasterSettings());
  EXPECT_LT((a.color - b.color.to(torch::kFloat64)).abs().max().item<double>(), 1e-4);
  EXPECT_LT((a.depth - b.depth.to(torch::kFloat64)).abs().max().item<double>(), 1e-4);
}

// The twist is applied on the left: rendering with xi equals rendering with
// the camera Exp(xi) * cam_from_world.
TEST(TorchRasterize, TwistPerturbsTheCameraOnTheLeft) {
  RasterCamera cam = MakeCamera(48, 36, 40.0);
  SetPose(Rigid3d::Exp(Twist(0.1, 0.0, -0.05, 0.0, 0.05, 0.02)), &cam);
  const Scene s = RandomScene(40, 1, cam, 4, torch::kFloat64);
  const auto xi = Twist(0.02, -0.03, 0.04, -0.03, 0.02, 0.01);
  RasterCamera moved = cam;
  SetPose(Rigid3d::Exp(xi) * GetPose(cam), &moved);
  const torch::Tensor twist = torch::tensor({xi[0], xi[1], xi[2], xi[3], xi[4], xi[5]}, torch::kFloat64);
  const RasterizeResult a = Render(s, twist, cam, RasterSettings());
  const RasterizeResult b = Render(s, torch::Tensor(), moved, RasterSettings());
  const RasterizeResult c = Render(s, torch::Tensor(), cam, RasterSettings());
  EXPECT_LT((a.color - b.color).abs().max().item<double>(), 1e-9);
  EXPECT_GT((a.color - c.color).abs().max().item<double>(), 1e-2);
}

// ---------------------------------------------------------------------------
// (3) Adam fits a random Gaussian set to a target image.

TEST(TorchRasterize, AdamStepsReduceThePhotometricLoss) {
  const RasterCamera cam = MakeCamera(64, 48, 55.0);
  RasterSettings settings;
  settings.sh_degree = 0;
  settings.num_threads = 1;  // many tiny renders: threads would only add overhead on a busy machine
  const Scene target_scene = RandomScene(40, 1, cam, 31, torch::kFloat32);
  const torch::Tensor target = Render(target_scene, torch::Tensor(), cam, settings).color;
  Scene s = RandomScene(40, 1, cam, 32, torch::kFloat32);
  s.RequireGrad();
  torch::optim::Adam adam(s.All(), torch::optim::AdamOptions(0.02));
  std::vector<double> losses;
  for (int step = 0; step < 40; ++step) {
    adam.zero_grad();
    const torch::Tensor loss = (Render(s, torch::Tensor(), cam, settings).color - target).abs().mean();
    loss.backward();
    adam.step();
    losses.push_back(loss.item<double>());
  }
  EXPECT_LT(losses.back(), 0.6 * losses.front()) << "first " << losses.front() << " last " << losses.back();
  RecordProperty("loss", std::to_string(losses.front()) + " -> " + std::to_string(losses.back()));
  for (const torch::Tensor& t : s.All()) EXPECT_TRUE(torch::isfinite(t).all().item<bool>());
}

// ---------------------------------------------------------------------------
// (4) Pose refinement: optimising the twist with the photometric loss brings
// a perturbed camera back to the true pose.

TEST(TorchRasterize, TwistOptimisationReducesThePoseError) {
  RasterCamera truth = MakeCamera(64, 48, 55.0);
  const Scene s = RandomScene(150, 1, truth, 41, torch::kFloat32, 2.0, 4.0, 0.04, 0.12, 1.0, 3.0);
  const Rigid3d true_pose = Rigid3d::Exp(Twist(0.02, 0.01, -0.03, 0.01, -0.02, 0.01));
  SetPose(true_pose, &truth);
  RasterSettings settings;
  settings.sh_degree = 0;
  settings.num_threads = 1;
  const RasterizeResult target = Render(s, torch::Tensor(), truth, settings);

  RasterCamera start = truth;
  SetPose(Rigid3d::Exp(Twist(0.03, -0.02, 0.03, 0.012, -0.01, 0.015)) * true_pose, &start);
  torch::Tensor twist = torch::zeros({6}, torch::requires_grad());
  auto pose_error = [&]() {
    const torch::Tensor x = twist.detach().to(torch::kFloat64);
    const auto xi = Twist(x[0].item<double>(), x[1].item<double>(), x[2].item<double>(), x[3].item<double>(),
                          x[4].item<double>(), x[5].item<double>());
    return ((Rigid3d::Exp(xi) * GetPose(start)) * true_pose.Inverse()).Log().norm();
  };
  const double initial_error = pose_error();
  torch::optim::Adam adam({twist}, torch::optim::AdamOptions(2e-3));
  double first_loss = 0, last_loss = 0;
  for (int step = 0; step < 80; ++step) {
    adam.zero_grad();
    const RasterizeResult r = Render(s, twist, start, settings);
    const torch::Tensor loss =
        (r.color - target.color).square().mean() + 0.1 * (r.depth - target.depth).square().mean();
    loss.backward();
    adam.step();
    (step == 0 ? first_loss : last_loss) = loss.item<double>();
  }
  const double final_error = pose_error();
  EXPECT_LT(final_error, 0.25 * initial_error) << "initial " << initial_error << " final " << final_error;
  RecordProperty("pose_error", std::to_string(initial_error) + " -> " + std::to_string(final_error));
  EXPECT_LT(last_loss, first_loss);
}

// ---------------------------------------------------------------------------
// The |dL/d mean2d| probe.

TEST(TorchRasterize, ProbeGradientAccumulatesOverRenders) {
  const RasterCamera cam = MakeCamera(32, 24, 30.0);
  Scene s = RandomScene(15, 1, cam, 51, torch::kFloat32);
  s.means.requires_grad_(true);
  const torch::Tensor probe = MakeMean2dAbsProbe(s.means);
  EXPECT_EQ(probe.sizes(), torch::IntArrayRef({15}));
  EXPECT_TRUE(probe.requires_grad());
  const LossWeights w = RandomWeights(cam, torch::kFloat32, 52);
  WeightedLoss(Render(s, torch::Tensor(), cam, RasterSettings(), probe), w).backward();
  const torch::Tensor once = probe.grad().clone();
  EXPECT_GT(once.sum().item<float>(), 0.0f);
  // Only drawn Gaussians get a value.
  const torch::Tensor drawn = Render(s, torch::Tensor(), cam, RasterSettings()).radii.gt(0);
  EXPECT_EQ((once.gt(0) & drawn.logical_not()).sum().item<int64_t>(), 0);
  WeightedLoss(Render(s, torch::Tensor(), cam, RasterSettings(), probe), w).backward();
  EXPECT_TRUE(torch::allclose(probe.grad(), 2 * once));
  // Without a probe nothing else changes.
  const torch::Tensor means_grad = s.means.grad().clone();
  s.means.grad().zero_();
  WeightedLoss(Render(s, torch::Tensor(), cam, RasterSettings()), w).backward();
  EXPECT_TRUE(torch::allclose(s.means.grad(), 0.5 * means_grad));
}

// ---------------------------------------------------------------------------
// (5) Bad input names the tensor and what was found.

TEST(TorchRasterize, BadInputsNameTheTensor) {
  const RasterCamera cam = MakeCamera(32, 24, 30.0);
  const RasterSettings settings;
  const Scene good = RandomScene(5, 4, cam, 61, torch::kFloat32);
  auto render_with = [&](const std::function<void(Scene*, torch::Tensor*, torch::Tensor*)>& edit) {
    return [&, edit]() {
      Scene s = good;
      torch::Tensor twist = torch::zeros({6});
      torch::Tensor probe;
      edit(&s, &twist, &probe);
      Render(s, twist, cam, settings, probe);
    };
  };
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->means = s->means.to(torch::kInt32); }),
                {"`means`", "int32"});
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->means = s->means.to(torch::kHalf); }),
                {"`means`", "float16"});
  ExpectInvalid(
      render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->log_scales = s->log_scales.to(torch::kFloat64); }),
      {"`log_scales`", "float64"});
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->means = s->means.narrow(1, 0, 2); }),
                {"`means`", "[5, 2]"});
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->quats = s->quats.narrow(1, 0, 3); }),
                {"`quats`", "[N, 4]", "[5, 3]"});
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->quats = s->quats.narrow(0, 0, 4); }),
                {"`quats`", "[4, 4]"});
  ExpectInvalid(
      render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->opacity_logits = torch::zeros({5, 2}); }),
      {"`opacity_logits`", "[5, 2]"});
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->sh = torch::zeros({5, 5, 3}); }),
                {"`sh`", "[5, 5, 3]", "{1, 4, 9, 16}"});
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->sh = torch::zeros({5, 4}); }),
                {"`sh`", "[5, 4]"});
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) { s->sh = torch::Tensor(); }),
                {"`sh`", "undefined"});
  ExpectInvalid(render_with([](Scene*, torch::Tensor* twist, torch::Tensor*) { *twist = torch::zeros({5}); }),
                {"`cam_twist`", "[6]", "[5]"});
  ExpectInvalid(
      render_with([](Scene*, torch::Tensor* twist, torch::Tensor*) { *twist = torch::full({6}, NAN); }),
      {"`cam_twist`", "non-finite"});
  ExpectInvalid(render_with([](Scene*, torch::Tensor*, torch::Tensor* probe) { *probe = torch::zeros({6}); }),
                {"`mean2d_abs_probe`", "[6]"});
  // Devices: the meta device stands in for "another device" on a CPU-only machine.
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) {
                  s->log_scales = torch::empty({5, 3}, torch::device(torch::kMeta));
                }),
                {"`log_scales`", "meta", "`means` is on cpu"});
  ExpectInvalid(render_with([](Scene* s, torch::Tensor*, torch::Tensor*) {
                  s->means = torch::empty({5, 3}, torch::device(torch::kMeta));
                }),
                {"`means`", "meta", "cpu or cuda"});
  // Camera and settings errors come from the kernels' validation.
  RasterCamera bad_cam = cam;
  bad_cam.width = 0;
  ExpectInvalid([&]() { Render(good, torch::Tensor(), bad_cam, settings); }, {"image size"});
  RasterSettings bad_settings;
  bad_settings.near_plane = -1.0f;
  ExpectInvalid([&]() { Render(good, torch::Tensor(), cam, bad_settings); }, {"near_plane"});
  std::string why;
  if (!kernels::BackendAvailable(kernels::Backend::kCuda, &why)) {
    EXPECT_FALSE(why.empty());
  }
}

// ---------------------------------------------------------------------------
// (6) No Gaussians: the background, and a backward that works.

TEST(TorchRasterize, EmptySceneRendersTheBackground) {
  const RasterCamera cam = MakeCamera(64, 48, 55.0);
  RasterSettings settings;
  settings.background[0] = 0.2f;
  settings.background[1] = 0.4f;
  settings.background[2] = 0.6f;
  Scene s = RandomScene(0, 4, cam, 71, torch::kFloat32);
  s.RequireGrad();
  torch::Tensor twist = torch::zeros({6}, torch::requires_grad());
  const RasterizeResult r = Render(s, twist, cam, settings, MakeMean2dAbsProbe(s.means));
  ASSERT_EQ(r.color.sizes(), torch::IntArrayRef({48, 64, 3}));
  const torch::Tensor bg = torch::tensor({0.2f, 0.4f, 0.6f}).expand({48, 64, 3});
  EXPECT_TRUE(torch::equal(r.color, bg));
  EXPECT_EQ(r.depth.abs().max().item<float>(), 0.0f);
  EXPECT_EQ(r.alpha.abs().max().item<float>(), 0.0f);
  EXPECT_EQ(r.radii.numel(), 0);
  (r.color.sum() + r.depth.sum()).backward();
  EXPECT_EQ(s.means.grad().sizes(), torch::IntArrayRef({0, 3}));
  EXPECT_EQ(s.sh.grad().sizes(), torch::IntArrayRef({0, 4, 3}));
  EXPECT_TRUE(torch::equal(twist.grad(), torch::zeros({6})));
}

// ---------------------------------------------------------------------------
// CUDA tensors run the CUDA backend: same outputs and gradients as the CPU
// within float tolerances. Skipped without a device (or a CUDA build).

TEST(TorchRasterize, CudaMatchesCpu) {
  std::string why;
  if (!torch::cuda::is_available() || !kernels::BackendAvailable(kernels::Backend::kCuda, &why)) {
    GTEST_SKIP() << "no CUDA: " << (why.empty() ? "LibTorch sees no CUDA device" : why);
  }
  const RasterCamera cam = MakeCamera(64, 48, 55.0);
  RasterSettings settings;
  settings.background[2] = 0.5f;
  const Scene base = RandomScene(50, 4, cam, 81, torch::kFloat32);
  const LossWeights w = RandomWeights(cam, torch::kFloat32, 82);
  struct Run {
    RasterizeResult result;
    std::vector<torch::Tensor> grads;  // five parameters, twist, probe
  };
  auto run = [&](torch::Device device) {
    Scene s = CloneScene(base);
    for (torch::Tensor* t : {&s.means, &s.log_scales, &s.quats, &s.opacity_logits, &s.sh}) *t = t->to(device);
    s.RequireGrad();
    torch::Tensor twist = torch::zeros({6}, torch::device(device).requires_grad(true));
    torch::Tensor probe = MakeMean2dAbsProbe(s.means);
    Run out;
    out.result = Render(s, twist, cam, settings, probe);
    WeightedLoss(out.result, {w.color.to(device), w.depth.to(device), w.alpha.to(device)}).backward();
    for (const torch::Tensor& t : s.All()) out.grads.push_back(t.grad().cpu());
    out.grads.push_back(twist.grad().cpu());
    out.grads.push_back(probe.grad().cpu());
    return out;
  };
  const Run cpu = run(torch::kCPU);
  const Run gpu = run(torch::Device(torch::kCUDA, 0));
  EXPECT_TRUE(gpu.result.color.is_cuda());
  EXPECT_LT((cpu.result.color - gpu.result.color.cpu()).abs().max().item<float>(), 1e-4f);
  EXPECT_LT((cpu.result.depth - gpu.result.depth.cpu()).abs().max().item<float>(), 1e-4f);
  EXPECT_LT((cpu.result.alpha - gpu.result.alpha.cpu()).abs().max().item<float>(), 1e-4f);
  // A radius is a rounded-up float: allow one Gaussian to round differently.
  EXPECT_LE(cpu.result.radii.ne(gpu.result.radii.cpu()).sum().item<int64_t>(), 1);
  for (size_t i = 0; i < cpu.grads.size(); ++i) {
    const float scale = 1.0f + cpu.grads[i].abs().max().item<float>();
    EXPECT_LT((cpu.grads[i] - gpu.grads[i]).abs().max().item<float>(), 1e-3f * scale) << "gradient " << i;
  }
}

// ---------------------------------------------------------------------------
// LibTorch's intra-op threads.

TEST(TorchRasterize, ConfigureTorchThreads) {
  const int before = at::get_num_threads();
  ConfigureTorchThreads(1);
  EXPECT_EQ(at::get_num_threads(), 1);
  ConfigureTorchThreads(0);
  EXPECT_EQ(at::get_num_threads(), DefaultThreadCount());
  ExpectInvalid([]() { ConfigureTorchThreads(-2); }, {"num_threads", "-2"});
  ConfigureTorchThreads(before);
}

}  // namespace
}  // namespace dypho
