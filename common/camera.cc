#include "common/camera.h"

#include <cmath>
#include <sstream>

#include "common/check.h"

namespace dypho {

bool Camera::HasDistortion() const {
  for (double d : distortion) {
    if (d != 0.0) return true;
  }
  return false;
}

bool Camera::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(std::isfinite(fx) && fx > 0)) msg << "fx must be finite and > 0 (got " << fx << ")";
  else if (!(std::isfinite(fy) && fy > 0)) msg << "fy must be finite and > 0 (got " << fy << ")";
  else if (!std::isfinite(cx)) msg << "cx must be finite (got " << cx << ")";
  else if (!std::isfinite(cy)) msg << "cy must be finite (got " << cy << ")";
  else if (width <= 0) msg << "width must be > 0 (got " << width << ")";
  else if (height <= 0) msg << "height must be > 0 (got " << height << ")";
  else {
    for (int i = 0; i < 5; ++i) {
      if (!std::isfinite(distortion[i])) {
        msg << "distortion[" << i << "] must be finite";
        break;
      }
    }
  }
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

bool Camera::IsPlausibleCalibration(std::string* error) const {
  if (!IsValid(error)) return false;
  // The principal point lies on the image (a calibration puts it near the
  // centre; 1e9 is a typo or an attack), and the field of view is between
  // about 0.006 and 179.9 degrees.
  std::ostringstream msg;
  if (!(cx >= -0.5 && cx <= width - 0.5)) {
    msg << "cx must lie on the image, in [-0.5, width - 0.5 = " << width - 0.5 << "] (got " << cx << ")";
  } else if (!(cy >= -0.5 && cy <= height - 0.5)) {
    msg << "cy must lie on the image, in [-0.5, height - 0.5 = " << height - 0.5 << "] (got " << cy << ")";
  } else if (!(fx >= 1e-3 * width && fx <= 1e4 * width)) {
    msg << "fx must be in [width / 1000, width * 10000] = [" << 1e-3 * width << ", " << 1e4 * width << "] (got "
        << fx << ")";
  } else if (!(fy >= 1e-3 * height && fy <= 1e4 * height)) {
    msg << "fy must be in [height / 1000, height * 10000] = [" << 1e-3 * height << ", " << 1e4 * height
        << "] (got " << fy << ")";
  }
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

void Camera::ValidateCalibration(const std::string& what) const {
  std::string error;
  DYPHO_CHECK_INPUT(IsPlausibleCalibration(&error)) << what << ": camera " << error;
}

void Camera::Validate(const std::string& what) const {
  std::string error;
  DYPHO_CHECK_INPUT(IsValid(&error)) << what << ": camera " << error;
}

Eigen::Vector2d Camera::Project(const Eigen::Vector3d& p) const {
  return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy};
}

Eigen::Vector3d Camera::Unproject(const Eigen::Vector2d& pixel, double z) const {
  return {(pixel.x() - cx) / fx * z, (pixel.y() - cy) / fy * z, z};
}

Eigen::Vector2d Camera::Distort(const Eigen::Vector2d& ideal) const {
  if (!HasDistortion()) return ideal;
  const double x = (ideal.x() - cx) / fx;
  const double y = (ideal.y() - cy) / fy;
  const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3],
               k3 = distortion[4];
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
  return {fx * xd + cx, fy * yd + cy};
}

Eigen::Vector2d Camera::Undistort(const Eigen::Vector2d& distorted) const {
  if (!HasDistortion()) return distorted;
  // Fixed-point iteration on normalised coordinates (as cv::undistortPoints).
  const double xd = (distorted.x() - cx) / fx;
  const double yd = (distorted.y() - cy) / fy;
  const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3],
               k3 = distortion[4];
  double x = xd, y = yd;
  for (int it = 0; it < 20; ++it) {
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    const double dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    x = (xd - dx) / radial;
    y = (yd - dy) / radial;
  }
  return {fx * x + cx, fy * y + cy};
}

Camera Camera::Scaled(double factor) const {
  Camera c = *this;
  c.fx *= factor;
  c.fy *= factor;
  // Pixel centres at integers: scaling maps u -> (u + 0.5) * f - 0.5.
  c.cx = (cx + 0.5) * factor - 0.5;
  c.cy = (cy + 0.5) * factor - 0.5;
  c.width = static_cast<int>(std::lround(width * factor));
  c.height = static_cast<int>(std::lround(height * factor));
  return c;
}

Camera Camera::FromFov(int width, int height, double horizontal_fov) {
  Camera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.5 * width / std::tan(0.5 * horizontal_fov);
  c.cx = 0.5 * width - 0.5;
  c.cy = 0.5 * height - 0.5;
  return c;
}

}  // namespace dypho
