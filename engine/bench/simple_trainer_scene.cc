// Options, the random scene and the target image of the simple-trainer
// benchmark (the training loop is engine/torch/simple_trainer.cc).
#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "common/files.h"
#include "engine/bench/simple_trainer.h"
#include "engine/io/image_io.h"

namespace dypho {

TrainerOptimizer ParseTrainerOptimizer(const std::string& name) {
  if (name == "own") return TrainerOptimizer::kOwn;
  if (name == "torch") return TrainerOptimizer::kTorch;
  DYPHO_CHECK_INPUT(false) << "optimizer '" << name << "' is unknown (expected own or torch)";
  return TrainerOptimizer::kOwn;
}

const char* TrainerOptimizerName(TrainerOptimizer optimizer) {
  return optimizer == TrainerOptimizer::kTorch ? "torch" : "own";
}

bool SimpleTrainerOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (num_gaussians < 1 || num_gaussians > 50000000) {
    msg << "num_gaussians = " << num_gaussians << " must be in [1, 50000000]";
  } else if (iterations < 1) {
    msg << "iterations = " << iterations << " must be at least 1";
  } else if (warmup < 0) {
    msg << "warmup = " << warmup << " must not be negative";
  } else if (!(learning_rate > 0.0f) || !std::isfinite(learning_rate)) {
    msg << "learning_rate = " << learning_rate << " must be positive and finite";
  } else if (threads < 0 || threads > kMaxThreads) {
    msg << "threads = " << threads << " must be in [0, " << kMaxThreads << "] (0 = all cores)";
  }
  if (msg.tellp() == 0) return true;
  if (error) *error = msg.str();
  return false;
}

TrainerScene MakeTrainerScene(int num_gaussians, uint32_t seed) {
  TrainerScene s;
  const size_t n = static_cast<size_t>(num_gaussians);
  s.means.reserve(3 * n);
  s.log_scales.reserve(3 * n);
  s.quats.reserve(4 * n);
  s.opacity_logits.assign(n, 1.0f);
  s.sh.reserve(3 * n);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float two_pi = 2.0f * static_cast<float>(M_PI);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) s.means.push_back(2.0f * u(rng) - 1.0f);
    for (int k = 0; k < 3; ++k) s.log_scales.push_back(std::log(std::max(u(rng), 1e-6f)));
    // Uniform random rotation (Shoemake, "Uniform random rotations", 1992).
    const float u1 = u(rng), u2 = u(rng), u3 = u(rng);
    const float a = std::sqrt(1 - u1), b = std::sqrt(u1);
    s.quats.insert(s.quats.end(), {a * std::sin(two_pi * u2), a * std::cos(two_pi * u2), b * std::sin(two_pi * u3),
                                   b * std::cos(two_pi * u3)});
    // Colour uniform in [0, 1): SH DC coefficient (c - 0.5) / C0.
    for (int c = 0; c < 3; ++c) s.sh.push_back((u(rng) - 0.5f) / 0.28209479177387814f);
  }
  return s;
}

ImageF SyntheticTrainerPicture(int width, int height) {
  DYPHO_CHECK_INPUT(width > 0 && height > 0) << "picture size " << width << "x" << height << " is invalid";
  ImageF img(width, height, 3, 0.0f);
  const float cx = 0.62f * width, cy = 0.45f * height, r = 0.22f * std::min(width, height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float fx = (x + 0.5f) / width, fy = (y + 0.5f) / height;
      float rgb[3] = {0.2f + 0.6f * fx, 0.3f + 0.5f * fy, 0.8f - 0.5f * fx * fy};
      if (std::hypot(x + 0.5f - cx, y + 0.5f - cy) < r) {
        rgb[0] = 0.9f, rgb[1] = 0.75f, rgb[2] = 0.1f;
      } else if (fx < 0.35f && fy > 0.55f && (static_cast<int>(fy * 24) % 2 == 0)) {
        rgb[0] = rgb[1] = rgb[2] = 0.05f;
      }
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = rgb[c];
    }
  }
  return img;
}

ImageF LoadTrainerImage(const std::string& path, int width, int height) {
  DYPHO_CHECK_INPUT(width > 0 && height > 0) << "image size " << width << "x" << height << " is invalid";
  const ImageU8 rgb = ReadRgb8(path);
  if (rgb.width() == width && rgb.height() == height) return ToFloat(rgb);
  const cv::Mat src(rgb.height(), rgb.width(), CV_8UC3, const_cast<uint8_t*>(rgb.data()));
  ImageU8 resized(width, height, 3);
  cv::Mat dst(height, width, CV_8UC3, resized.data());
  const bool shrink = width < rgb.width() && height < rgb.height();
  cv::resize(src, dst, dst.size(), 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
  return ToFloat(resized);
}

}  // namespace dypho
