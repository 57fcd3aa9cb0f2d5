#include "engine/synth/shore/shore_motion.h"

#include <cmath>

#include <Eigen/Geometry>

#include "engine/synth/shore/shore_layout.h"

namespace dypho::synth {

Rigid3d ShoreCameraPose(const ShoreSynthOptions& options, double t) {
  constexpr double kDeg = M_PI / 180.0;
  const double w = 2.0 * M_PI;
  const Eigen::Vector3d centre(-1.0 + options.boat_speed_own * t, 0.15 * std::sin(0.31 * t),
                               kCameraHeight + 0.04 * std::sin(w * 0.35 * t + 0.5));
  const double roll = options.roll_deg * kDeg * std::sin(w * 0.22 * t);
  const double pitch = (2.0 + 1.2 * std::sin(w * 0.17 * t + 1.0)) * kDeg;  // positive: looking up
  const double yaw = 4.0 * kDeg * std::sin(w * 0.05 * t + 0.3);
  // Camera axes in the world when level: x = +x, y (down) = -z, z (forward) = +y.
  Eigen::Matrix3d level;
  level << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix() *
                            level;
  return Rigid3d(Eigen::Quaterniond(r), centre);
}

Trajectory ShoreTrajectory(const ShoreSynthOptions& options) {
  Trajectory trajectory;
  for (int i = 0; i < options.frames; ++i) {
    trajectory.Add(options.Timestamp(i), ShoreCameraPose(options, i / options.fps));
  }
  return trajectory;
}

}  // namespace dypho::synth
