// Viewing rays of every pixel of a camera, and projection of camera-frame
// points to (distorted) pixels: the geometry shared by the rigid-flow
// prediction and the background-depth warp. Pixel centres lie at integer
// coordinates (common/camera.h).
#pragma once

#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/rigid3.h"

namespace dypho {

class PixelRays {
 public:
  // Throws InvalidInput when the camera is invalid.
  explicit PixelRays(const Camera& camera);

  const Camera& camera() const { return camera_; }
  cv::Size size() const { return {camera_.width, camera_.height}; }
  // Normalised undistorted ray (x/z, y/z) of pixel (u, v): a point at depth z
  // seen at that pixel is z * (x/z, y/z, 1).
  const cv::Vec2f& Ray(int u, int v) const { return rays_.at<cv::Vec2f>(v, u); }
  // CV_32FC2, camera size.
  const cv::Mat& rays() const { return rays_; }

  // Pixel (with the camera's distortion) of camera-frame point (x, y, z);
  // false when z <= 1e-6.
  bool Project(float x, float y, float z, float* u, float* v) const {
    if (!(z > 1e-6f)) return false;
    float xn = x / z, yn = y / z;
    if (distorted_) {
      const float r2 = xn * xn + yn * yn;
      const float radial = 1.0f + r2 * (k1_ + r2 * (k2_ + r2 * k3_));
      const float xd = xn * radial + 2.0f * p1_ * xn * yn + p2_ * (r2 + 2.0f * xn * xn);
      const float yd = yn * radial + p1_ * (r2 + 2.0f * yn * yn) + 2.0f * p2_ * xn * yn;
      xn = xd;
      yn = yd;
    }
    *u = fx_ * xn + cx_;
    *v = fy_ * yn + cy_;
    return true;
  }

 private:
  Camera camera_;
  cv::Mat rays_;
  bool distorted_ = false;
  float fx_, fy_, cx_, cy_, k1_, k2_, p1_, p2_, k3_;
};

// A rigid transform as float rotation matrix and translation, for per-pixel loops.
struct RigidF {
  float r[9];
  float t[3];
  explicit RigidF(const Rigid3d& transform);
  void Apply(float x, float y, float z, float* ox, float* oy, float* oz) const {
    *ox = r[0] * x + r[1] * y + r[2] * z + t[0];
    *oy = r[3] * x + r[4] * y + r[5] * z + t[1];
    *oz = r[6] * x + r[7] * y + r[8] * z + t[2];
  }
};

}  // namespace dypho
