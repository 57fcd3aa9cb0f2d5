// Map files chosen by their extension, and the static dense point cloud
// (voxel grid, neighbour distances and outlier removal with known answers).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "common/check.h"
#include "engine/export/export.h"
#include "engine/export/ply.h"
#include "engine/export/point_cloud.h"
#include "engine/gaussians.h"
#include "kernels/math/sh.h"
#include "tests/export_test_util.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using ::dypho::testing::TestTempDir;
using export_testing::ExpectSameCloud;
using export_testing::RandomCloud;
using export_testing::ReadAll;
using export_testing::SplitPly;
using export_testing::TestPly;

// ---------------------------------------------------------------------------
// Map files by extension

TEST(MapFiles, FormatFollowsTheExtension) {
  const std::string dir = TestTempDir();
  const GaussianCloud cloud = RandomCloud(5, 9, 30);
  SaveMap(cloud, dir + "/a.PLY");
  ExpectSameCloud(LoadMap(dir + "/a.PLY"), cloud);
  SaveMap(cloud, dir + "/a.splat");
  EXPECT_EQ(fs::file_size(dir + "/a.splat"), 5u * 32);
  EXPECT_EQ(LoadMap(dir + "/a.splat").size(), 5);
  SaveMap(cloud, dir + "/a.glb");
  EXPECT_EQ(ReadAll(dir + "/a.glb").substr(0, 4), "glTF");
  EXPECT_INVALID_INPUT(SaveMap(cloud, dir + "/a.obj"), "a.obj: unknown map format '.obj'");
  EXPECT_EQ(LoadMap(dir + "/a.glb").size(), 5);
}

// ---------------------------------------------------------------------------
// Static dense point cloud

ColoredPoints MakePoints(const std::vector<std::vector<float>>& xyz, const std::vector<std::vector<int>>& rgb) {
  ColoredPoints points;
  for (size_t i = 0; i < xyz.size(); ++i) {
    points.xyz.insert(points.xyz.end(), xyz[i].begin(), xyz[i].end());
    for (int c : rgb[i]) points.rgb.push_back(static_cast<uint8_t>(c));
  }
  return points;
}

TEST(PointCloud, VoxelGridKnownAnswer) {
  // Cells of 0.5 m: (0,0,0) holds two points, (-1,0,0) and (1,0,0) one each
  // (floor, not truncation, for negative coordinates).
  const ColoredPoints points = MakePoints({{0.1f, 0.1f, 0.1f}, {-0.1f, 0.0f, 0.2f}, {0.3f, 0.3f, 0.4f}, {0.6f, 0, 0}},
                                          {{10, 20, 30}, {1, 2, 3}, {20, 40, 61}, {7, 8, 9}});
  const ColoredPoints out = VoxelGridDownsample(points, 0.5);
  ASSERT_EQ(out.size(), 3);
  // First-occurrence order: cell (0,0,0), then (-1,0,0), then (1,0,0).
  EXPECT_FLOAT_EQ(out.xyz[0], 0.2f);
  EXPECT_FLOAT_EQ(out.xyz[1], 0.2f);
  EXPECT_FLOAT_EQ(out.xyz[2], 0.25f);
  EXPECT_EQ(out.rgb[0], 15);
  EXPECT_EQ(out.rgb[1], 30);
  EXPECT_EQ(out.rgb[2], 46);  // 45.5 rounds up
  EXPECT_FLOAT_EQ(out.xyz[3], -0.1f);
  EXPECT_EQ(out.rgb[3], 1);
  EXPECT_FLOAT_EQ(out.xyz[6], 0.6f);
  EXPECT_EQ(out.rgb[8], 9);
  EXPECT_INVALID_INPUT(VoxelGridDownsample(points, 0.0), "voxel_size must be positive");
}

TEST(PointCloud, NeighbourDistancesMatchBruteForce) {
  // Known answer on a line x = 0, 1, 2, 3.
  const ColoredPoints line = MakePoints({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}}, {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}});
  EXPECT_EQ(MeanNeighborDistances(line, 1), (std::vector<double>{1, 1, 1, 1}));
  EXPECT_EQ(MeanNeighborDistances(line, 2), (std::vector<double>{1.5, 1, 1, 1.5}));
  EXPECT_EQ(MeanNeighborDistances(line, 10), (std::vector<double>{2, 4.0 / 3, 4.0 / 3, 2}));  // k -> 3

  // Random clustered points against an O(n^2) search.
  std::mt19937 rng(3);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  ColoredPoints points;
  for (int i = 0; i < 1500; ++i) {
    const float cx = static_cast<float>(i % 5) * 3.0f;
    points.xyz.insert(points.xyz.end(), {cx + normal(rng), normal(rng) * 0.3f, normal(rng) * 2.0f});
    points.rgb.insert(points.rgb.end(), {0, 0, 0});
  }
  const int k = 7;
  const std::vector<double> fast = MeanNeighborDistances(points, k);
  for (int i = 0; i < points.size(); ++i) {
    std::vector<double> d;
    for (int j = 0; j < points.size(); ++j) {
      if (j == i) continue;
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double diff = double(points.xyz[3 * j + a]) - points.xyz[3 * i + a];
        d2 += diff * diff;
      }
      d.push_back(d2);
    }
    std::partial_sort(d.begin(), d.begin() + k, d.end());
    double sum = 0;
    for (int j = 0; j < k; ++j) sum += std::sqrt(d[j]);
    ASSERT_NEAR(fast[i], sum / k, 1e-12) << "point " << i;
  }
}

TEST(PointCloud, OutlierRemovalDropsFarPointsAndKeepsOrder) {
  // A 5x5x5 grid (spacing 0.1 m) with three far points mixed in.
  ColoredPoints points;
  std::vector<float> expected;
  int index = 0;
  for (int x = 0; x < 5; ++x) {
    for (int y = 0; y < 5; ++y) {
      for (int z = 0; z < 5; ++z, ++index) {
        if (index == 10) points.xyz.insert(points.xyz.end(), {5.0f, 0.0f, 0.0f});
        if (index == 70) points.xyz.insert(points.xyz.end(), {-7.0f, 1.0f, 0.0f});
        const std::vector<float> p = {0.1f * x, 0.1f * y, 0.1f * z};
        points.xyz.insert(points.xyz.end(), p.begin(), p.end());
        expected.insert(expected.end(), p.begin(), p.end());
      }
    }
  }
  points.xyz.insert(points.xyz.end(), {0.2f, 10.0f, 0.2f});
  points.rgb.assign(points.xyz.size(), 100);
  ASSERT_EQ(points.size(), 128);
  // Grid points: mean distance to 4 neighbours 0.1 (inside) to 0.11 (corners);
  // the far points about 5, 7 and 10 m; mu + 1 sigma is about 1.4 m.
  const ColoredPoints kept = RemoveStatisticalOutliers(points, 4, 1.0);
  EXPECT_EQ(kept.xyz, expected);
  EXPECT_EQ(kept.rgb.size(), expected.size());
  // A ratio so large that nothing is removed.
  EXPECT_EQ(RemoveStatisticalOutliers(points, 4, 100.0).size(), 128);
}

TEST(PointCloud, OutlierThresholdUsesTheSampleStandardDeviation) {
  // k = 1 distances on a line: d = 1, 1, 1, 1, 2, 2. mu = 4/3, sample sigma =
  // sqrt((4/3) / 5) = 0.5164 (population sigma 0.4714). The last two points
  // stay iff mu + ratio sigma >= 2, i.e. ratio >= 1.291 (1.414 with the
  // population sigma).
  const ColoredPoints line = MakePoints({{0, 0, 0}, {1, 0, 0}, {10, 0, 0}, {11, 0, 0}, {30, 0, 0}, {32, 0, 0}},
                                        std::vector<std::vector<int>>(6, {1, 2, 3}));
  EXPECT_EQ(MeanNeighborDistances(line, 1), (std::vector<double>{1, 1, 1, 1, 2, 2}));
  EXPECT_EQ(RemoveStatisticalOutliers(line, 1, 1.25).size(), 4);
  EXPECT_EQ(RemoveStatisticalOutliers(line, 1, 1.35).size(), 6);
  EXPECT_EQ(RemoveStatisticalOutliers(line, 1, 1.25).xyz,
            (std::vector<float>{0, 0, 0, 1, 0, 0, 10, 0, 0, 11, 0, 0}));
}

TEST(PointCloud, FromGaussiansPipelineAndPly) {
  const std::string dir = TestTempDir();
  GaussianCloud cloud;
  const float log_scale[3] = {-3, -3, -3};
  const float quat[4] = {1, 0, 0, 0};
  // Two opaque Gaussians in one 1 m cell, one transparent, one in another cell.
  const float means[4][3] = {{0.1f, 0.2f, 0.3f}, {0.3f, 0.4f, 0.5f}, {0.5f, 0.5f, 0.5f}, {2.5f, 0.5f, 0.5f}};
  const float logits[4] = {3.0f, 3.0f, -3.0f, 3.0f};
  const float dc[4][3] = {{RgbToShDc(1.0f), RgbToShDc(0.0f), RgbToShDc(0.5f)},
                          {RgbToShDc(0.0f), RgbToShDc(0.0f), RgbToShDc(0.5f)},
                          {RgbToShDc(1.0f), RgbToShDc(1.0f), RgbToShDc(1.0f)},
                          {5.0f, -5.0f, 0.0f}};
  for (int i = 0; i < 4; ++i) cloud.Add(means[i], log_scale, quat, logits[i], dc[i]);

  const ColoredPoints all = PointsFromGaussians(cloud);
  ASSERT_EQ(all.size(), 4);
  EXPECT_EQ(all.rgb, (std::vector<uint8_t>{255, 0, 128, 0, 0, 128, 255, 255, 255, 255, 0, 128}));
  EXPECT_EQ(PointsFromGaussians(cloud, 0.5).size(), 3);  // sigmoid(-3) = 0.047 is skipped

  PointCloudOptions options;
  options.min_opacity = 0.5;
  options.voxel_size = 1.0;
  const ColoredPoints points = StaticPointCloud(cloud, options);
  ASSERT_EQ(points.size(), 2);
  EXPECT_FLOAT_EQ(points.xyz[0], 0.2f);
  EXPECT_FLOAT_EQ(points.xyz[2], 0.4f);
  EXPECT_EQ(points.rgb[0], 128);  // (255 + 0) / 2 = 127.5 rounds up
  EXPECT_FLOAT_EQ(points.xyz[3], 2.5f);

  SavePointCloudPly(points, dir + "/points.ply");
  const TestPly ply = SplitPly(ReadAll(dir + "/points.ply"));
  EXPECT_EQ(ply.header_lines,
            (std::vector<std::string>{"ply", "format binary_little_endian 1.0", "element vertex 2", "property float x",
                                      "property float y", "property float z", "property uchar red",
                                      "property uchar green", "property uchar blue", "end_header"}));
  ASSERT_EQ(ply.body.size(), 2u * 15);
  for (int i = 0; i < 2; ++i) {
    float xyz[3];
    std::memcpy(xyz, ply.body.data() + 15 * i, 12);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(xyz[a], points.xyz[3 * i + a]);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(static_cast<uint8_t>(ply.body[15 * i + 12 + c]), points.rgb[3 * i + c]);
  }

  // An empty cloud gives a valid PLY with no vertices.
  SavePointCloudPly(StaticPointCloud(GaussianCloud(), PointCloudOptions()), dir + "/empty.ply");
  EXPECT_EQ(SplitPly(ReadAll(dir + "/empty.ply")).header_lines[2], "element vertex 0");

  std::string error;
  options.voxel_size = -1;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("voxel_size"), std::string::npos);
  EXPECT_INVALID_INPUT(StaticPointCloud(cloud, options), "PointCloudOptions: voxel_size must be >= 0");
}

}  // namespace
}  // namespace dypho
