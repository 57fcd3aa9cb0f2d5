// SensorWarp (engine/torch/sensor_warp.h): the same image as the sensor
// model's OpenCV implementation (engine/map/sensor_model.h) and as the
// grid_sample fallback, and a backward pass that is the exact adjoint of the
// forward warp (<W x, y> = <x, W^T y>) and matches finite differences.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "engine/map/sensor_model.h"
#include "engine/torch/sensor_warp.h"

namespace dypho {
namespace {

const Camera kCamera{120, 118, 39.5, 29.5, 80, 60};

torch::Tensor Homographies(const Eigen::Vector3d& omega, const SensorModel& model, int* samples) {
  *samples = SensorSampleCount(kCamera, omega, model);
  std::vector<float> h = SensorRowHomographies(kCamera, omega, model, *samples);
  return torch::from_blob(h.data(), {*samples, kCamera.height, 3, 3}, torch::kFloat32).clone();
}

SensorModel Model() {
  SensorModel m;
  m.readout = 0.03;
  m.exposure = 0.03;
  return m;
}

const Eigen::Vector3d kOmega(0.8, -2.0, 1.2);

TEST(SensorWarp, MatchesTheOpenCvSensorModelAndTheGridSampleFallback) {
  torch::manual_seed(3);
  // A smooth image (cv::remap interpolates with 1/32 px fixed-point weights).
  const torch::Tensor image =
      torch::nn::functional::interpolate(torch::rand({1, 3, 15, 20}),
                                         torch::nn::functional::InterpolateFuncOptions()
                                             .size(std::vector<int64_t>{60, 80})
                                             .mode(torch::kBilinear)
                                             .align_corners(false))
          .squeeze(0)
          .permute({1, 2, 0})
          .contiguous();
  int n = 0;
  const torch::Tensor hom = Homographies(kOmega, Model(), &n);
  ASSERT_GT(n, 2);
  const torch::Tensor fused = SensorWarp(image, hom);
  ImageF img(80, 60, 3);
  std::memcpy(img.data(), image.data_ptr<float>(), img.size() * sizeof(float));
  const ImageF cv = ApplySensorModel(img, kCamera, kOmega, Model());
  const torch::Tensor cv_t = torch::from_blob(const_cast<float*>(cv.data()), {60, 80, 3}, torch::kFloat32);
  EXPECT_LT((fused - cv_t).abs().max().item<float>(), 0.01f);
  EXPECT_GT(fused.abs().sum().item<float>(), 100.0f);
  // The fallback (taken for double images) agrees closely.
  const torch::Tensor fallback = SensorWarp(image.to(torch::kFloat64), hom.to(torch::kFloat64)).to(torch::kFloat32);
  EXPECT_LT((fused - fallback).abs().max().item<float>(), 1e-4f);
}

TEST(SensorWarp, BackwardIsTheAdjointAndMatchesFiniteDifferences) {
  torch::manual_seed(5);
  int n = 0;
  const torch::Tensor hom = Homographies(kOmega, Model(), &n);
  const torch::Tensor x = torch::rand({60, 80, 3}).requires_grad_(true);
  const torch::Tensor y = torch::rand({60, 80, 3});
  const torch::Tensor wx = SensorWarp(x, hom);
  const torch::Tensor inner = (wx * y).sum();
  inner.backward();
  const torch::Tensor wty = x.grad();
  // <W x, y> = <x, W^T y> (W is linear).
  const double lhs = inner.item<double>();
  const double rhs = (x.detach().to(torch::kFloat64) * wty.to(torch::kFloat64)).sum().item<double>();
  EXPECT_NEAR(lhs, rhs, 1e-4 * std::abs(lhs));
  // Central differences on a few pixels.
  for (int64_t p : {0L, 1234L, 7000L, 14399L}) {
    const int64_t py = p / 80 % 60, px = p % 80, ch = p % 3;
    torch::Tensor plus = x.detach().clone(), minus = x.detach().clone();
    plus[py][px][ch] += 0.5f;
    minus[py][px][ch] -= 0.5f;
    const double fd = ((SensorWarp(plus, hom) * y).sum().item<double>() -
                       (SensorWarp(minus, hom) * y).sum().item<double>());
    EXPECT_NEAR(fd, wty[py][px][ch].item<double>(), 1e-3) << "pixel " << px << "," << py;
  }
}

}  // namespace
}  // namespace dypho
