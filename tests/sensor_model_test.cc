// The rolling-shutter and motion-blur model (engine/map/sensor_model.h) on
// known answers: where each sensor row looks in the global-shutter render
// under a known rotation rate, the length and energy of a blur streak, the
// angular velocity from two poses, and bad input.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "engine/map/sensor_model.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

const Camera kCamera{500, 500, 79.5, 59.5, 160, 120};

TEST(SensorModel, StillCameraReadsEveryPixelInPlace) {
  SensorModel model;
  model.readout = 0.03;
  model.exposure = 0.02;
  const std::vector<float> pos = SensorSamplePositions(kCamera, Eigen::Vector3d::Zero(), model, 3);
  ASSERT_EQ(pos.size(), 3u * 160 * 120 * 2);
  for (int j = 0; j < 3; ++j) {
    for (int y = 0; y < 120; y += 7) {
      for (int x = 0; x < 160; x += 5) {
        const size_t i = ((static_cast<size_t>(j) * 120 + y) * 160 + x) * 2;
        EXPECT_FLOAT_EQ(pos[i], x);
        EXPECT_FLOAT_EQ(pos[i + 1], y);
      }
    }
  }
  EXPECT_EQ(SensorSampleCount(kCamera, Eigen::Vector3d::Zero(), model), 1);
}

TEST(SensorModel, RollingShutterRowsLookWhereTheCameraPointedWhenTheyWereRead) {
  // Turning about the camera's y axis at 2 rad/s: row v was read at
  // tau = readout (v / (H - 1) - 0.5) by the camera Exp(omega tau) cam_mid, so
  // column 80 (next to cx) sees the render where R_y(-theta) sends its ray,
  // theta = 2 tau; the middle rows barely move.
  SensorModel model;
  model.readout = 0.04;
  const Eigen::Vector3d omega(0, 2.0, 0);
  const std::vector<float> pos = SensorSamplePositions(kCamera, omega, model, 1);
  for (int y : {0, 30, 60, 90, 119}) {
    const double tau = model.readout * (y / 119.0 - 0.5);
    const double theta = 2.0 * tau;
    // Ray (a, b, 1) rotated by R_y(-theta): (a cos - sin, b, a sin + cos).
    const double b = (y - kCamera.cy) / kCamera.fy;
    const size_t i = (static_cast<size_t>(y) * 160 + 80) * 2;
    const double a = (80 - kCamera.cx) / kCamera.fx;
    const double qx = a * std::cos(theta) - std::sin(theta), qz = a * std::sin(theta) + std::cos(theta);
    EXPECT_NEAR(pos[i], kCamera.fx * qx / qz + kCamera.cx, 1e-3) << "row " << y;
    EXPECT_NEAR(pos[i + 1], kCamera.fy * b / qz + kCamera.cy, 1e-3) << "row " << y;
  }
  // Top and bottom rows are displaced in opposite directions by about
  // f * omega * readout / 2 = 20 px.
  EXPECT_NEAR(pos[(0 * 160 + 80) * 2] - 80, 20.0, 0.5);
  EXPECT_NEAR(pos[(119 * 160 + 80) * 2] - 80, -20.0, 0.5);
}

TEST(SensorModel, MotionBlurSpreadsALineOverTheStreakAndKeepsItsEnergy) {
  // A one-pixel bright column at x = 80, camera turning about y at 1 rad/s
  // for a 20 ms exposure: the streak is f * omega * exposure = 10 px wide.
  SensorModel model;
  model.exposure = 0.02;
  const Eigen::Vector3d omega(0, 1.0, 0);
  EXPECT_EQ(SensorSampleCount(kCamera, omega, model), 5);  // ceil(10 px / 1.5 px) = 7, at most max_samples 5
  ImageF render(160, 120, 1, 0.0f);
  for (int y = 0; y < 120; ++y) render.at(80, y) = 1.0f;
  model.max_samples = 40;
  EXPECT_EQ(SensorSampleCount(kCamera, omega, model), 7);
  const ImageF blurred = ApplySensorModel(render, kCamera, omega, model);
  const int y = 60;
  double sum = 0;
  int first = -1, last = -1;
  for (int x = 0; x < 160; ++x) {
    const float v = blurred.at(x, y);
    sum += v;
    if (v > 1e-4f) {
      if (first < 0) first = x;
      last = x;
    }
  }
  EXPECT_NEAR(sum, 1.0, 0.03);  // energy kept
  EXPECT_NEAR(last - first + 1, 10, 1.5);
  EXPECT_NEAR(0.5 * (first + last), 80.0, 1.0);  // centred: the exposure is centred on the row's time
  // Without motion the image is unchanged.
  const ImageF same = ApplySensorModel(render, kCamera, Eigen::Vector3d::Zero(), model);
  for (int x = 0; x < 160; ++x) EXPECT_NEAR(same.at(x, y), render.at(x, y), 1e-6);
}

TEST(SensorModel, AngularVelocityFromTwoPoses) {
  const Rigid3d a(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX())), Eigen::Vector3d(1, 2, 3));
  const Eigen::Vector3d omega(0.5, -1.0, 2.0);
  const double dt = 0.02;
  const Eigen::Quaterniond step(Eigen::AngleAxisd(omega.norm() * dt, omega.normalized()));
  const Rigid3d b(step * a.rotation, a.translation);
  const Eigen::Vector3d got = AngularVelocity(a, 10.0, b, 10.0 + dt);
  EXPECT_NEAR((got - omega).norm(), 0.0, 1e-9);
  EXPECT_INVALID_INPUT(AngularVelocity(a, 1.0, b, 1.0), "increasing");
}

TEST(SensorModel, BadInputIsAClearError) {
  SensorModel model;
  model.readout = -0.01;
  EXPECT_INVALID_INPUT(model.Validate(), "readout");
  model.readout = 0.0;
  model.exposure = std::nan("");
  EXPECT_INVALID_INPUT(model.Validate(), "exposure");
  model.exposure = 0.01;
  EXPECT_INVALID_INPUT(ApplySensorModel(ImageF(10, 10, 3), kCamera, Eigen::Vector3d(0, 1, 0), model), "render is 10x10");
  Camera distorted = kCamera;
  distorted.distortion[0] = 0.1;
  EXPECT_INVALID_INPUT(SensorSamplePositions(distorted, Eigen::Vector3d(0, 1, 0), model, 2), "undistorted");
  EXPECT_INVALID_INPUT(SensorSamplePositions(kCamera, Eigen::Vector3d(NAN, 0, 0), model, 2), "finite");
}

}  // namespace
}  // namespace dypho
