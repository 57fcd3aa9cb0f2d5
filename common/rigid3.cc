#include "common/rigid3.h"

#include <cmath>

namespace dypho {
namespace {
Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}
// Left Jacobian of SO(3): V in exp([rho, phi]) = [exp(phi), V rho].
Eigen::Matrix3d LeftJacobian(const Eigen::Vector3d& phi) {
  const double theta = phi.norm();
  const Eigen::Matrix3d k = Hat(phi);
  if (theta < 1e-8) return Eigen::Matrix3d::Identity() + 0.5 * k;
  const double t2 = theta * theta;
  return Eigen::Matrix3d::Identity() + (1.0 - std::cos(theta)) / t2 * k +
         (theta - std::sin(theta)) / (t2 * theta) * k * k;
}
}  // namespace

Rigid3d Rigid3d::FromMatrix(const Eigen::Matrix<double, 3, 4>& m) {
  return Rigid3d(Eigen::Quaterniond(Eigen::Matrix3d(m.leftCols<3>())), m.col(3));
}

Eigen::Matrix<double, 3, 4> Rigid3d::ToMatrix() const {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = rotation.toRotationMatrix();
  m.col(3) = translation;
  return m;
}

Eigen::Matrix4d Rigid3d::ToMatrix4() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topRows<3>() = ToMatrix();
  return m;
}

Rigid3d Rigid3d::Inverse() const {
  const Eigen::Quaterniond inv = rotation.conjugate();
  return Rigid3d(inv, -(inv * translation));
}

Rigid3d Rigid3d::Exp(const Eigen::Matrix<double, 6, 1>& twist) {
  const Eigen::Vector3d rho = twist.head<3>();
  const Eigen::Vector3d phi = twist.tail<3>();
  const double theta = phi.norm();
  Eigen::Quaterniond q = theta < 1e-12 ? Eigen::Quaterniond::Identity()
                                       : Eigen::Quaterniond(Eigen::AngleAxisd(theta, phi / theta));
  return Rigid3d(q, LeftJacobian(phi) * rho);
}

Eigen::Matrix<double, 6, 1> Rigid3d::Log() const {
  Eigen::AngleAxisd aa(rotation);
  Eigen::Vector3d phi = aa.axis() * aa.angle();
  if (!std::isfinite(phi.x())) phi.setZero();
  Eigen::Matrix<double, 6, 1> out;
  out.head<3>() = LeftJacobian(phi).inverse() * translation;
  out.tail<3>() = phi;
  return out;
}

double RotationAngle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

Rigid3d Interpolate(const Rigid3d& a, const Rigid3d& b, double t) {
  return Rigid3d(a.rotation.slerp(t, b.rotation),
                 (1.0 - t) * a.translation + t * b.translation);
}

}  // namespace dypho
