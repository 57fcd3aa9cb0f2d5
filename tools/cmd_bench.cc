// dypho bench simple-trainer: the classic simple-trainer scene (N random
// Gaussians fitted to one image), seconds per iteration with dypho's Adam or
// LibTorch's, for one-to-one comparison with OpenSplat's and gsplat's
// simple_trainer.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/files.h"
#include "engine/bench/simple_trainer.h"
#include "tools/command.h"

namespace dypho::tools {
namespace {

// The first frame of the head250 sequence when the shared data sits beside
// the checkout (the working directory's ../shared), else empty.
std::string DefaultTrainerImage() {
  namespace fs = std::filesystem;
  const fs::path dir = "../shared/data/tum_fr1_rpy_head250/rgb";
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return "";
  std::vector<std::string> pngs;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.path().extension() == ".png") pngs.push_back(e.path().string());
  }
  std::sort(pngs.begin(), pngs.end());
  return pngs.empty() ? "" : pngs.front();
}

int RunSimpleTrainerBench(const std::string& image_flag, bool synthetic, int width, int height,
                          const SimpleTrainerOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  const std::string image = synthetic ? "" : (image_flag.empty() ? DefaultTrainerImage() : image_flag);
  const ImageF target = image.empty() ? SyntheticTrainerPicture(width, height) : LoadTrainerImage(image, width, height);
  std::printf("simple-trainer: %d Gaussians, %dx%d, target %s, optimizer %s, %d warm-up + %d iterations\n",
              options.num_gaussians, width, height, image.empty() ? "synthetic picture" : image.c_str(),
              TrainerOptimizerName(options.optimizer), options.warmup, options.iterations);
  const SimpleTrainerResult r = RunSimpleTrainer(options, target);
  std::printf("threads %d\n", r.num_threads);
  std::printf("seconds per iteration: median %.4f, mean %.4f (min %.4f, max %.4f)\n", r.median_seconds,
              r.mean_seconds, *std::min_element(r.seconds.begin(), r.seconds.end()),
              *std::max_element(r.seconds.begin(), r.seconds.end()));
  std::printf("L1 loss: first %.5f, final %.5f; final PSNR %.2f dB\n", r.loss.front(), r.final_loss, r.final_psnr);
  return 0;
}

int RunBench(int argc, char** argv) {
  CLI::App app{"Benchmarks."};
  app.require_subcommand(1);
  CLI::App* st = app.add_subcommand(
      "simple-trainer",
      "N random Gaussians fitted to one image (render, L1 loss, backward, Adam step per iteration); seconds per "
      "iteration");
  SimpleTrainerOptions options;
  std::string image, optimizer = "own";
  bool synthetic = false;
  int width = 640, height = 480;
  st->add_option("--gaussians", options.num_gaussians, "number of random Gaussians")
      ->capture_default_str()
      ->check(CLI::Range(1, 50000000));
  st->add_option("--width", width, "rendered width [px]")->capture_default_str()->check(CLI::Range(1, 16384));
  st->add_option("--height", height, "rendered height [px]")->capture_default_str()->check(CLI::Range(1, 16384));
  // Integer ranges: CLI::PositiveNumber printed "Value 0 not in range 0.000000
  // to 1797...(300 digits)" for --iters 0.
  st->add_option("--iters", options.iterations, "timed iterations")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000000));
  st->add_option("--warmup", options.warmup, "iterations run first and not timed")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000000000));
  st->add_option("--image", image,
                 "image to fit (resized to --width x --height); default: the first head250 frame in "
                 "../shared/data, else a built-in synthetic picture")
      ->check(CLI::ExistingFile);
  st->add_flag("--synthetic", synthetic, "fit the built-in synthetic picture")->excludes("--image");
  st->add_option("--optimizer", optimizer, "own (dypho's Adam) or torch (torch::optim::Adam)")
      ->capture_default_str()
      ->check(CLI::IsMember({"own", "torch"}));
  st->add_option("--lr", options.learning_rate, "Adam learning rate")->capture_default_str()->check(
      CLI::PositiveNumber);
  st->add_option("--threads", options.threads, "CPU threads (0 = all cores, at most " + std::to_string(kMaxThreads) + ")")
      ->capture_default_str()
      ->check(CLI::Range(0, kMaxThreads));
  st->add_option("--seed", options.seed, "random scene seed")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  options.optimizer = ParseTrainerOptimizer(optimizer);
  return RunSimpleTrainerBench(image, synthetic, width, height, options);
}

}  // namespace

DYPHO_COMMAND("bench", "benchmarks: simple-trainer (random Gaussians fitted to one image, s/iteration)", RunBench);

}  // namespace dypho::tools
