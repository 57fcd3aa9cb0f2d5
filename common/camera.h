// Pinhole camera intrinsics with optional radial-tangential distortion
// (OpenCV's k1 k2 p1 p2 k3 model). Pixel centres lie at integer coordinates:
// pixel (u, v) covers [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5], as in OpenCV
// and the TUM calibration.
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>

namespace dypho {

struct Camera {
  double fx = 0.0;    // focal length along x [px]
  double fy = 0.0;    // focal length along y [px]
  double cx = 0.0;    // principal point x [px]
  double cy = 0.0;    // principal point y [px]
  int width = 0;      // image width [px]
  int height = 0;     // image height [px]
  // Distortion k1 k2 p1 p2 k3 (OpenCV order); all zero means none.
  std::array<double, 5> distortion{0.0, 0.0, 0.0, 0.0, 0.0};

  bool HasDistortion() const;
  // True when the values make sense; otherwise fills `error` with the field
  // and the violated constraint.
  bool IsValid(std::string* error) const;
  // Throws InvalidInput naming `what` when !IsValid.
  void Validate(const std::string& what) const;
  // IsValid, and the intrinsics fit the image as a real calibration does:
  // the principal point on the image, focal lengths within
  // [size / 1000, size * 1e4] (fields of view from 0.006 to 179.9 degrees).
  // Cameras read from files and the mapper's camera must pass; a render
  // camera need not (a view may be off-centre on purpose).
  bool IsPlausibleCalibration(std::string* error) const;
  // Throws InvalidInput naming `what` and the field when !IsPlausibleCalibration.
  void ValidateCalibration(const std::string& what) const;

  // Ideal (undistorted) projection of a camera-frame point, z > 0.
  Eigen::Vector2d Project(const Eigen::Vector3d& point_in_cam) const;
  // Back-projection of an ideal pixel at depth z (camera-frame z, not range).
  Eigen::Vector3d Unproject(const Eigen::Vector2d& pixel, double z) const;
  // Distorted pixel -> ideal pixel (iterative inversion of the model).
  Eigen::Vector2d Undistort(const Eigen::Vector2d& distorted_pixel) const;
  // Ideal pixel -> distorted pixel.
  Eigen::Vector2d Distort(const Eigen::Vector2d& ideal_pixel) const;

  // The same camera for an image scaled by `factor` (e.g. 0.5 halves it).
  Camera Scaled(double factor) const;
  // A camera with the given horizontal field of view [rad], centred.
  static Camera FromFov(int width, int height, double horizontal_fov);
};

}  // namespace dypho
