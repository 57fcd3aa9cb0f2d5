#include "masking/pixel_rays.h"

namespace dypho {

PixelRays::PixelRays(const Camera& camera) : camera_(camera) {
  camera.Validate("PixelRays");
  distorted_ = camera.HasDistortion();
  fx_ = static_cast<float>(camera.fx);
  fy_ = static_cast<float>(camera.fy);
  cx_ = static_cast<float>(camera.cx);
  cy_ = static_cast<float>(camera.cy);
  k1_ = static_cast<float>(camera.distortion[0]);
  k2_ = static_cast<float>(camera.distortion[1]);
  p1_ = static_cast<float>(camera.distortion[2]);
  p2_ = static_cast<float>(camera.distortion[3]);
  k3_ = static_cast<float>(camera.distortion[4]);
  rays_.create(camera.height, camera.width, CV_32FC2);
  for (int v = 0; v < camera.height; ++v) {
    cv::Vec2f* row = rays_.ptr<cv::Vec2f>(v);
    for (int u = 0; u < camera.width; ++u) {
      const Eigen::Vector2d ideal = camera.Undistort(Eigen::Vector2d(u, v));
      row[u] = cv::Vec2f(static_cast<float>((ideal.x() - camera.cx) / camera.fx),
                         static_cast<float>((ideal.y() - camera.cy) / camera.fy));
    }
  }
}

RigidF::RigidF(const Rigid3d& transform) {
  const Eigen::Matrix3d rotation = transform.rotation.toRotationMatrix();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r[3 * i + j] = static_cast<float>(rotation(i, j));
    t[i] = static_cast<float>(transform.translation[i]);
  }
}

}  // namespace dypho
