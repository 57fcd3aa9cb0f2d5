// The "simple trainer" benchmark scene (gsplat's and OpenSplat's
// simple_trainer): N random Gaussians fitted to one image, each iteration a
// render, an L1 loss, the backward pass and an Adam step, so that dypho's
// seconds per iteration compare one to one with those programs. The scene is
// workload 1 of tests/bench/rasterizer_bench.cc: means uniform in [-1, 1]^3,
// linear scales uniform in [0, 1), uniformly random rotations, opacity
// sigmoid(1), uniform colours (SH degree 0), camera 8 units from the cube's
// centre with a 90 degree horizontal field of view. All five parameter
// tensors are optimised with one learning rate. CPU backend.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/image.h"

namespace dypho {

enum class TrainerOptimizer {
  kOwn,    // dypho's Adam (engine/torch/adam.h, the mapper's optimiser)
  kTorch,  // LibTorch's torch::optim::Adam
};

// "own" or "torch"; throws InvalidInput naming the value otherwise.
TrainerOptimizer ParseTrainerOptimizer(const std::string& name);
const char* TrainerOptimizerName(TrainerOptimizer optimizer);

struct SimpleTrainerOptions {
  int num_gaussians = 100000;                       // Gaussians fitted to the image
  int iterations = 100;                             // timed iterations after the warm-up
  int warmup = 3;                                   // iterations run first and not timed
  TrainerOptimizer optimizer = TrainerOptimizer::kOwn;
  float learning_rate = 0.01f;                      // Adam step size, all parameters
  int threads = 0;                                  // rasterizer and LibTorch threads; 0 = all cores
  uint32_t seed = 42;                               // random scene

  // False (with the field and the violated constraint in `error`) when invalid.
  bool IsValid(std::string* error) const;
};

struct SimpleTrainerResult {
  std::vector<double> seconds;  // wall time of each timed iteration [s]
  std::vector<double> loss;     // L1 loss of every iteration (warm-up first), before its step
  double median_seconds = 0;    // over `seconds` [s]
  double mean_seconds = 0;      // over `seconds` [s]
  double final_loss = 0;        // L1 loss of the image after the last step
  double final_psnr = 0;        // PSNR [dB] of the image after the last step (peak 1)
  int num_threads = 0;          // threads the run used
};

// Runs the benchmark on `target` (RGB float in [0, 1], 3 channels; its size
// is the rendered size). Throws InvalidInput for invalid options or image.
SimpleTrainerResult RunSimpleTrainer(const SimpleTrainerOptions& options, const ImageF& target);

// A deterministic picture to fit when no image is given: smooth colour
// gradients, a disc and stripes (edges and flat areas, like a photograph).
ImageF SyntheticTrainerPicture(int width, int height);

// Reads an 8-bit image file as RGB in [0, 1], resized (area averaging) to
// width x height when its size differs. Errors name the file.
ImageF LoadTrainerImage(const std::string& path, int width, int height);

// The random scene as plain arrays (kernels::GaussianParams layout, SH
// degree 0): [N, 3] means, [N, 3] log scales, [N, 4] quaternions (w, x, y, z),
// [N] opacity logits, [N, 1, 3] SH.
struct TrainerScene {
  std::vector<float> means, log_scales, quats, opacity_logits, sh;
};
TrainerScene MakeTrainerScene(int num_gaussians, uint32_t seed);

}  // namespace dypho
