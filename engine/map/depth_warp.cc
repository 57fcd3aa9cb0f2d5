#include "engine/map/depth_warp.h"

#include <cmath>

#include "common/check.h"

namespace dypho {

ImageF WarpDepth(const ImageF& depth, const Camera& camera, const Rigid3d& target_from_source) {
  DYPHO_CHECK_INPUT(depth.width() == camera.width && depth.height() == camera.height && depth.channels() == 1)
      << "WarpDepth: depth is " << depth.width() << "x" << depth.height() << "x" << depth.channels()
      << ", the camera " << camera.width << "x" << camera.height << "x1";
  const int w = depth.width(), h = depth.height();
  ImageF out(w, h, 1, 0.0f);
  const Eigen::Matrix3d r = target_from_source.rotation.toRotationMatrix();
  const Eigen::Vector3d t = target_from_source.translation;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float z = depth.at(x, y);
      if (!(z > 0) || !std::isfinite(z)) continue;
      const Eigen::Vector3d q = r * Eigen::Vector3d((x - camera.cx) * z / camera.fx, (y - camera.cy) * z / camera.fy, z) + t;
      if (q.z() <= 0) continue;
      const int u = static_cast<int>(std::lround(camera.fx * q.x() / q.z() + camera.cx));
      const int v = static_cast<int>(std::lround(camera.fy * q.y() / q.z() + camera.cy));
      if (u < 0 || v < 0 || u >= w || v >= h) continue;
      float& d = out.at(u, v);
      const float qz = static_cast<float>(q.z());
      if (d == 0.0f || qz < d) d = qz;
    }
  }
  ImageF filled = out;
  for (int y = 1; y + 1 < h; ++y) {
    for (int x = 1; x + 1 < w; ++x) {
      if (out.at(x, y) > 0) continue;
      const float l = out.at(x - 1, y), r2 = out.at(x + 1, y), u = out.at(x, y - 1), d = out.at(x, y + 1);
      if (l > 0 && r2 > 0 && std::abs(l - r2) < 0.05f * std::min(l, r2)) {
        filled.at(x, y) = 0.5f * (l + r2);
      } else if (u > 0 && d > 0 && std::abs(u - d) < 0.05f * std::min(u, d)) {
        filled.at(x, y) = 0.5f * (u + d);
      }
    }
  }
  return filled;
}

}  // namespace dypho
