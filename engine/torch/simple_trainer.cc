// The training loop of the simple-trainer benchmark
// (engine/bench/simple_trainer.h): render, L1 loss, backward, Adam step, with
// dypho's Adam (AdamParam, the mapper's optimiser) or LibTorch's
// torch::optim::Adam. Both use beta (0.9, 0.999), eps 1e-15 and the same
// learning rate for every parameter, so that they take the same steps up to
// rounding.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numeric>

#include <torch/torch.h>

#include "common/check.h"
#include "engine/bench/simple_trainer.h"
#include "engine/torch/adam.h"
#include "engine/torch/rasterize.h"
#include "engine/torch/threads.h"
#include "kernels/rasterizer.h"

namespace dypho {
namespace {

torch::Tensor FromVector(const std::vector<float>& values, std::vector<int64_t> shape) {
  return torch::from_blob(const_cast<float*>(values.data()), shape, torch::kFloat32).clone();
}

kernels::RasterCamera TrainerCamera(int width, int height) {
  kernels::RasterCamera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = 0.5 * width / std::tan(0.25 * M_PI);  // 90 degree horizontal field of view
  cam.cx = 0.5 * (width - 1);
  cam.cy = 0.5 * (height - 1);
  cam.cam_from_world[11] = 8.0;  // the cube's centre is 8 units ahead
  return cam;
}

// The five optimised tensors with one of the two optimisers.
class TrainerParams {
 public:
  TrainerParams(const TrainerScene& scene, int n, TrainerOptimizer optimizer, float lr) : optimizer_(optimizer) {
    const torch::Tensor initial[5] = {FromVector(scene.means, {n, 3}), FromVector(scene.log_scales, {n, 3}),
                                      FromVector(scene.quats, {n, 4}), FromVector(scene.opacity_logits, {n}),
                                      FromVector(scene.sh, {n, 1, 3})};
    for (int i = 0; i < 5; ++i) params_[i].Init(initial[i], lr);
    if (optimizer_ == TrainerOptimizer::kTorch) {
      std::vector<torch::Tensor> values;
      for (const AdamParam& p : params_) values.push_back(p.value);
      torch_adam_ = std::make_unique<torch::optim::Adam>(
          values, torch::optim::AdamOptions(lr).betas({kAdamBeta1, kAdamBeta2}).eps(kAdamEps));
    }
    // Every row is stepped (plain Adam, as torch::optim::Adam does); the
    // all-true row mask selects AdamParam's fused CPU pass.
    all_rows_ = torch::ones({n}, torch::kBool);
  }
  const torch::Tensor& operator[](int i) const { return params_[i].value; }
  void ZeroGrad() {
    if (torch_adam_) torch_adam_->zero_grad();
  }
  void Step() {
    if (torch_adam_) {
      torch_adam_->step();
      return;
    }
    for (AdamParam& p : params_) p.Step(all_rows_);  // also clears the gradient
  }

 private:
  TrainerOptimizer optimizer_;
  AdamParam params_[5];
  std::unique_ptr<torch::optim::Adam> torch_adam_;
  torch::Tensor all_rows_;
};

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

SimpleTrainerResult RunSimpleTrainer(const SimpleTrainerOptions& options, const ImageF& target) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "simple trainer options: " << error;
  DYPHO_CHECK_INPUT(target.channels() == 3 && target.width() > 0 && target.height() > 0)
      << "simple trainer target image must be RGB with a positive size (found " << target.width() << "x"
      << target.height() << "x" << target.channels() << ")";
  ConfigureTorchThreads(options.threads);
  const int n = options.num_gaussians;
  const TrainerScene scene = MakeTrainerScene(n, options.seed);
  TrainerParams params(scene, n, options.optimizer, options.learning_rate);
  const torch::Tensor gt =
      torch::from_blob(const_cast<float*>(target.data()), {target.height(), target.width(), 3}, torch::kFloat32);
  const kernels::RasterCamera camera = TrainerCamera(target.width(), target.height());
  kernels::RasterSettings settings;
  settings.sh_degree = 0;
  settings.num_threads = options.threads;
  const auto render = [&] {
    return RasterizeGaussians(params[0], params[1], params[2], params[3], params[4], torch::Tensor(), camera, settings)
        .color;
  };

  SimpleTrainerResult result;
  result.num_threads = torch::get_num_threads();
  std::vector<torch::Tensor> losses;  // read after the loop: no host sync inside it
  const int total = options.warmup + options.iterations;
  for (int it = 0; it < total; ++it) {
    const auto t0 = std::chrono::steady_clock::now();
    params.ZeroGrad();
    const torch::Tensor loss = (render() - gt).abs().mean();
    loss.backward();
    params.Step();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    losses.push_back(loss.detach());
    if (it >= options.warmup) result.seconds.push_back(s);
  }
  for (const torch::Tensor& l : losses) result.loss.push_back(l.item<double>());
  result.median_seconds = Median(result.seconds);
  result.mean_seconds = std::accumulate(result.seconds.begin(), result.seconds.end(), 0.0) / result.seconds.size();
  {
    torch::NoGradGuard no_grad;
    const torch::Tensor diff = render() - gt;
    result.final_loss = diff.abs().mean().item<double>();
    const double mse = diff.square().mean().item<double>();
    result.final_psnr = mse > 0 ? -10.0 * std::log10(mse) : INFINITY;
  }
  return result;
}

}  // namespace dypho
