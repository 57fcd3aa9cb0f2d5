// Rigid transforms, named for what they map: `cam_from_world` takes a point in
// world coordinates to camera coordinates (x_cam = cam_from_world * x_world).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace dypho {

struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& r, const Eigen::Vector3d& t) : rotation(r.normalized()), translation(t) {}

  static Rigid3d FromMatrix(const Eigen::Matrix<double, 3, 4>& m);
  Eigen::Matrix<double, 3, 4> ToMatrix() const;
  Eigen::Matrix4d ToMatrix4() const;

  Rigid3d Inverse() const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return rotation * x + translation; }
  Rigid3d operator*(const Rigid3d& b) const {
    return Rigid3d(rotation * b.rotation, rotation * b.translation + translation);
  }

  // se(3) exponential / logarithm with the twist ordered (rho, phi):
  // translation part first, rotation (axis-angle) second.
  static Rigid3d Exp(const Eigen::Matrix<double, 6, 1>& twist);
  Eigen::Matrix<double, 6, 1> Log() const;
};

// Angle of the relative rotation between two rotations [rad].
double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);
// Spherical linear interpolation with t in [0, 1] (shortest path).
Rigid3d Interpolate(const Rigid3d& a, const Rigid3d& b, double t);

}  // namespace dypho
