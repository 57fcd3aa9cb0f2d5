// The dense map on real frames: tum_fr1_rpy_head250 with ground-truth poses.
// Every 10th frame is a keyframe; frames half way between keyframes are held
// back, and the dense points are compared with the surfaces those frames
// see (their depth, unprojected at the ground-truth pose).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "engine/dataset/dataset.h"
#include "engine/dense/dense_mapper.h"
#include "engine/export/knn.h"
#include "engine/map/undistort.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

double Percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * (v.size() - 1))];
}

TEST(DenseTum, PointsLieOnTheSurfacesOfHeldBackFrames) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  const auto dataset = OpenDataset(testing::SharedData("tum_fr1_rpy_head250"));
  ASSERT_TRUE(dataset->has_ground_truth());
  const Undistorter undistort(dataset->camera());
  const Camera& cam = undistort.pinhole();
  // The depth image's pose: ground truth at the depth timestamp (fr1/rpy
  // rotates fast; RGB and depth are up to 20 ms apart).
  auto depth_pose = [&](size_t i) {
    const std::optional<Rigid3d> p =
        InterpolatePose(dataset->ground_truth(), dataset->info(i).depth_timestamp, dataset->frames().size());
    return p;
  };
  DenseMapOptions options;  // the defaults a run uses
  DenseMapper dense(cam, options, true);
  int keyframes = 0;
  std::vector<float> surface;  // held-back depth, world frame
  std::vector<Rigid3d> heldout_poses;
  const auto start = std::chrono::steady_clock::now();
  for (size_t i = 0; i < dataset->size(); i += 5) {
    const FrameInfo& info = dataset->info(i);
    const std::optional<Rigid3d> world_from_cam = depth_pose(i);
    if (!info.has_depth || !world_from_cam) continue;
    const Frame frame = dataset->Load(i);
    KeyframeInput k;
    k.timestamp = frame.timestamp;
    k.rgb = undistort.Rgb(frame.rgb);
    k.depth = undistort.Depth(frame.depth);
    k.dynamic_mask = undistort.ExcludedPixels(ImageU8());
    k.cam_from_world = world_from_cam->Inverse();
    if (i % 10 == 0) {
      dense.Add(keyframes++, std::move(k));
      continue;
    }
    heldout_poses.push_back(k.cam_from_world);
    for (int y = 0; y < cam.height; y += 2) {
      for (int x = 0; x < cam.width; x += 2) {
        const float d = k.depth.at(x, y);
        if (!(d > 0.1f && d < options.points.max_depth)) continue;
        const Eigen::Vector3d p = *world_from_cam * Eigen::Vector3d((x - cam.cx) / cam.fx * d, (y - cam.cy) / cam.fy * d, d);
        for (int a = 0; a < 3; ++a) surface.push_back(static_cast<float>(p[a]));
      }
    }
  }
  const ColoredPoints cloud = dense.Cloud();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const DenseMapStats stats = dense.stats();
  EXPECT_EQ(keyframes, 25);
  EXPECT_EQ(stats.keyframes_added, 25);
  EXPECT_EQ(stats.empty_keyframes, 0);
  ASSERT_GT(cloud.size(), 20000);
  EXPECT_TRUE(cloud.has_normals());

  // Dense points inside the view of at least one held-back frame.
  std::vector<float> seen;
  for (int i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d p(cloud.xyz[3 * i], cloud.xyz[3 * i + 1], cloud.xyz[3 * i + 2]);
    for (const Rigid3d& cam_from_world : heldout_poses) {
      const Eigen::Vector3d c = cam_from_world * p;
      if (c.z() < 0.1) continue;
      const double u = cam.fx * c.x() / c.z() + cam.cx, v = cam.fy * c.y() / c.z() + cam.cy;
      if (u >= 0 && v >= 0 && u < cam.width && v < cam.height) {
        seen.insert(seen.end(), &cloud.xyz[3 * i], &cloud.xyz[3 * i] + 3);
        break;
      }
    }
  }
  const int n_seen = static_cast<int>(seen.size() / 3);
  ASSERT_GT(n_seen, cloud.size() / 2);
  const std::vector<double> d =
      NearestDistances(surface.data(), static_cast<int>(surface.size() / 3), seen.data(), n_seen);
  const double median = Percentile(d, 0.5), p90 = Percentile(d, 0.9);
  std::printf("dense head250: %d keyframes, %d points (%d in held-back views), %lld voxels, %.1f MB; distance to "
              "held-back surfaces: median %.4f m, 90th percentile %.4f m; %.2f ms per keyframe (max %.2f); %.1f s "
              "with loading\n",
              keyframes, cloud.size(), n_seen, static_cast<long long>(stats.map.voxels), stats.map.bytes / 1e6, median,
              p90, stats.mean_ms(), stats.max_ms, seconds);
  EXPECT_LT(median, 0.013);  // measured 0.0115 m (2 cm voxels)
  EXPECT_LT(p90, 0.045);    // measured 0.038 m
}

}  // namespace
}  // namespace dypho
