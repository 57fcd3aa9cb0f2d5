#include "engine/map/sensor_model.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "common/check.h"

namespace dypho {

void SensorModel::Validate() const {
  DYPHO_CHECK_INPUT(std::isfinite(readout) && readout >= 0 && readout < 0.2)
      << "sensor readout must be in [0, 0.2) s (got " << readout << ")";
  DYPHO_CHECK_INPUT(std::isfinite(exposure) && exposure >= 0 && exposure < 0.2)
      << "sensor exposure must be in [0, 0.2) s (got " << exposure << ")";
  DYPHO_CHECK_INPUT(max_samples >= 1 && max_samples <= 64)
      << "sensor max_samples must be in [1, 64] (got " << max_samples << ")";
}

Eigen::Vector3d AngularVelocity(const Rigid3d& cam_from_world_0, double t0, const Rigid3d& cam_from_world_1,
                                double t1) {
  DYPHO_CHECK_INPUT(std::isfinite(t0) && std::isfinite(t1) && t1 > t0)
      << "AngularVelocity: times must be finite and increasing (got " << t0 << ", " << t1 << ")";
  const Eigen::AngleAxisd aa(cam_from_world_1.rotation * cam_from_world_0.rotation.inverse());
  return aa.axis() * (aa.angle() / (t1 - t0));
}

Eigen::Vector3d AngularVelocitySince(const std::optional<Rigid3d>& previous, double previous_time,
                                     const Rigid3d& cam_from_world, double time) {
  if (!previous || !(time > previous_time) || time - previous_time >= kMaxAngularVelocityGap)
    return Eigen::Vector3d::Zero();
  return AngularVelocity(*previous, previous_time, cam_from_world, time);
}

int SensorSampleCount(const Camera& pinhole, const Eigen::Vector3d& omega, const SensorModel& model) {
  if (model.exposure <= 0) return 1;
  // Streak length at the image corner: rotation about the optical axis moves
  // it by |omega_z| r, about x/y by about f |omega_xy| (small angles).
  const double r = 0.5 * std::hypot(pinhole.width, pinhole.height);
  const double f = 0.5 * (pinhole.fx + pinhole.fy);
  const double rate = std::abs(omega.z()) * r + f * std::hypot(omega.x(), omega.y());
  const int n = static_cast<int>(std::ceil(rate * model.exposure / 1.5));
  return std::clamp(n, 1, model.max_samples);
}

std::vector<float> SensorRowHomographies(const Camera& pinhole, const Eigen::Vector3d& omega,
                                         const SensorModel& model, int samples) {
  DYPHO_CHECK_INPUT(!pinhole.HasDistortion()) << "the sensor model needs an undistorted (pinhole) camera";
  DYPHO_CHECK_INPUT(samples >= 1) << "sensor model: samples must be >= 1 (got " << samples << ")";
  DYPHO_CHECK_INPUT(omega.allFinite()) << "sensor model: angular velocity must be finite";
  const int h = pinhole.height;
  Eigen::Matrix3d k;
  k << pinhole.fx, 0, pinhole.cx, 0, pinhole.fy, pinhole.cy, 0, 0, 1;
  const Eigen::Matrix3d k_inv = k.inverse();
  std::vector<float> out(static_cast<size_t>(samples) * h * 9);
  const double row_scale = h > 1 ? model.readout / (h - 1) : 0.0;
  for (int j = 0; j < samples; ++j) {
    const double s = model.exposure * ((j + 0.5) / samples - 0.5);
    for (int y = 0; y < h; ++y) {
      const double t = row_scale * y - 0.5 * model.readout + s;
      const Eigen::Vector3d phi = omega * t;
      const double angle = phi.norm();
      // R(omega t)^T: a ray of the camera at time t expressed in the middle camera.
      Eigen::Matrix3d rt = Eigen::Matrix3d::Identity();
      if (angle > 0) rt = Eigen::AngleAxisd(-angle, phi / angle).toRotationMatrix();
      const Eigen::Matrix3d hom = k * rt * k_inv;
      float* dst = out.data() + (static_cast<size_t>(j) * h + y) * 9;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) dst[3 * r + c] = static_cast<float>(hom(r, c));
      }
    }
  }
  return out;
}

std::vector<float> SensorSamplePositions(const Camera& pinhole, const Eigen::Vector3d& omega,
                                         const SensorModel& model, int samples) {
  const std::vector<float> hom = SensorRowHomographies(pinhole, omega, model, samples);
  const int w = pinhole.width, h = pinhole.height;
  std::vector<float> out(static_cast<size_t>(samples) * w * h * 2);
  for (int j = 0; j < samples; ++j) {
    for (int y = 0; y < h; ++y) {
      const float* m = hom.data() + (static_cast<size_t>(j) * h + y) * 9;
      float* row = out.data() + ((static_cast<size_t>(j) * h + y) * w) * 2;
      for (int x = 0; x < w; ++x) {
        const float z = m[6] * x + m[7] * y + m[8];
        float px = -1e6f, py = -1e6f;  // behind the camera: outside
        if (z > 1e-6f) {
          px = (m[0] * x + m[1] * y + m[2]) / z;
          py = (m[3] * x + m[4] * y + m[5]) / z;
        }
        row[2 * x] = px;
        row[2 * x + 1] = py;
      }
    }
  }
  return out;
}

}  // namespace dypho
