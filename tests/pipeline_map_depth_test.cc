// The map depth of `dypho run`'s background model: a depth image made at
// pose A and forward-warped to pose B must be the depth seen from B.
// Known answers: planes intersected with each pixel's ray (exact), and a
// plane of Gaussians rendered at A and at B.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "engine/pipeline/map_depth.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

Camera SmallCamera() { return Camera{120.0, 120.0, 79.5, 59.5, 160, 120}; }

// A plane n . X = k in world coordinates, limited to |X.x|, |X.y| <= half
// (infinite when half <= 0).
struct Plane {
  Eigen::Vector3d n;
  double k;
  double half = 0.0;
};

// Depth (camera z) of the nearest plane along each pixel's ray, 0 = none.
cv::Mat PlaneDepth(const std::vector<Plane>& planes, const Camera& c, const Rigid3d& cam_from_world) {
  const Rigid3d world_from_cam = cam_from_world.Inverse();
  const Eigen::Matrix3d r = world_from_cam.rotation.toRotationMatrix();
  const Eigen::Vector3d t = world_from_cam.translation;
  cv::Mat depth(c.height, c.width, CV_32FC1, cv::Scalar(0.0f));
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const Eigen::Vector3d d((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0);
      double best = 0.0;
      for (const Plane& p : planes) {
        const double denom = p.n.dot(r * d);
        if (std::abs(denom) < 1e-12) continue;
        const double z = (p.k - p.n.dot(t)) / denom;
        if (z <= 0) continue;
        const Eigen::Vector3d x = r * (z * d) + t;
        if (p.half > 0 && (std::abs(x.x()) > p.half || std::abs(x.y()) > p.half)) continue;
        if (best == 0.0 || z < best) best = z;
      }
      depth.at<float>(v, u) = static_cast<float>(best);
    }
  }
  return depth;
}

Rigid3d PoseB() {
  // 4 deg about an oblique axis and 8 cm of translation from A (= identity).
  const Eigen::Quaterniond q(Eigen::AngleAxisd(4.0 * M_PI / 180.0, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()));
  return Rigid3d(q, Eigen::Vector3d(0.05, -0.03, 0.06));
}

TEST(MapDepthWarp, IdentityKeepsTheImage) {
  const Camera c = SmallCamera();
  const std::vector<Plane> wall = {{Eigen::Vector3d(0.2, -0.1, 1.0).normalized(), 2.5}};
  const cv::Mat a = PlaneDepth(wall, c, Rigid3d());
  const cv::Mat w = WarpMapDepth(a, c, Rigid3d());
  EXPECT_EQ(cv::norm(a, w, cv::NORM_INF), 0.0);
}

TEST(MapDepthWarp, TiltedPlaneWarpedToBEqualsThePlaneSeenFromB) {
  const Camera c = SmallCamera();
  const std::vector<Plane> wall = {{Eigen::Vector3d(0.2, -0.1, 1.0).normalized(), 2.5}};
  const Rigid3d b = PoseB();
  const cv::Mat at_a = PlaneDepth(wall, c, Rigid3d());
  const cv::Mat warped = WarpMapDepth(at_a, c, b * Rigid3d().Inverse());
  const cv::Mat at_b = PlaneDepth(wall, c, b);
  int covered = 0, compared = 0;
  double max_error = 0.0, sum_error = 0.0;
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const float w = warped.at<float>(v, u), e = at_b.at<float>(v, u);
      if (w == 0.0f) continue;
      ++covered;
      ++compared;
      max_error = std::max(max_error, static_cast<double>(std::abs(w - e)));
      sum_error += std::abs(w - e);
    }
  }
  // B sees the whole wall; the part A did not see is a band along one side
  // (4 deg of 67 deg field of view, 8 cm at 2.5 m): less than 15 %.
  EXPECT_GT(covered, 0.85 * c.width * c.height);
  ASSERT_GT(compared, 0);
  // Nearest-pixel splatting shifts a sample by up to half a pixel; on this
  // slope that is a few millimetres of depth.
  EXPECT_LT(sum_error / compared, 0.003);
  EXPECT_LT(max_error, 0.012);
}

TEST(MapDepthWarp, NearerSurfaceWinsTheZBuffer) {
  const Camera c = SmallCamera();
  // A far wall and a 0.6 m square 1.5 m away in front of it; from B the
  // square covers wall pixels that A saw (the warp puts both there).
  const std::vector<Plane> scene = {{Eigen::Vector3d(0, 0, 1), 3.0}, {Eigen::Vector3d(0, 0, 1), 1.5, 0.3}};
  const Rigid3d b = PoseB();
  const cv::Mat warped = WarpMapDepth(PlaneDepth(scene, c, Rigid3d()), c, b);
  const cv::Mat at_b = PlaneDepth(scene, c, b);
  int square = 0, square_right = 0, wall = 0, wall_right = 0;
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const float w = warped.at<float>(v, u), e = at_b.at<float>(v, u);
      if (w == 0.0f) continue;
      const bool ok = std::abs(w - e) < 0.02f;
      if (e < 2.0f) {
        ++square;
        square_right += ok;
      } else {
        ++wall;
        wall_right += ok;
      }
    }
  }
  ASSERT_GT(square, 500);
  ASSERT_GT(wall, 5000);
  // Only pixels on the square's outline may differ (rounding of the edge).
  EXPECT_GT(square_right, 0.97 * square);
  EXPECT_GT(wall_right, 0.97 * wall);
}

TEST(MapDepthWarp, RenderedGaussianPlaneWarpedToBEqualsItsRenderAtB) {
  const Camera c = SmallCamera();
  // A wall of small round Gaussians at z = 2.5 m (world), 2 cm apart.
  GaussianCloud cloud;
  const float spacing = 0.02f, log_scale = std::log(0.015f), quat[4] = {1, 0, 0, 0}, coeffs[3] = {0.5f, 0.5f, 0.5f};
  const float scales[3] = {log_scale, log_scale, std::log(0.002f)};
  for (int i = -110; i <= 110; ++i) {
    for (int j = -85; j <= 85; ++j) {
      const float mean[3] = {i * spacing, j * spacing, 2.5f};
      cloud.Add(mean, scales, quat, 4.0f, coeffs);
    }
  }
  kernels::RasterSettings settings;
  settings.sh_degree = 0;
  settings.num_threads = 1;
  const Rigid3d b = PoseB();
  const cv::Mat at_a = RenderMapDepth(cloud, c, Rigid3d(), settings);
  const cv::Mat at_b = RenderMapDepth(cloud, c, b, settings);
  const cv::Mat exact_b = PlaneDepth({{Eigen::Vector3d(0, 0, 1), 2.5}}, c, b);
  const cv::Mat warped = WarpMapDepth(at_a, c, b);
  // The renders themselves see the plane (alpha > 0.5 everywhere inside).
  EXPECT_LT(cv::norm(at_b, exact_b, cv::NORM_L1) / (c.width * c.height), 0.005);
  int compared = 0, agree = 0;
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const float w = warped.at<float>(v, u), r = at_b.at<float>(v, u);
      if (w == 0.0f || r == 0.0f) continue;
      ++compared;
      agree += std::abs(w - r) < 0.01f;
    }
  }
  EXPECT_GT(compared, 0.85 * c.width * c.height);
  EXPECT_GT(agree, 0.99 * compared);
}

TEST(MapDepthWarp, WrongSizeIsAnError) {
  const Camera c = SmallCamera();
  EXPECT_INVALID_INPUT(WarpMapDepth(cv::Mat(10, 10, CV_32FC1, cv::Scalar(1.0f)), c, Rigid3d()), "WarpMapDepth");
}

}  // namespace
}  // namespace dypho
