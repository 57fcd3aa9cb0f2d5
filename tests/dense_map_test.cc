// The dense point-cloud map (engine/dense/): pixel selection, the voxel map
// and its pose updates, the export filters and the thread, on synthetic
// keyframes with exact answers.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "engine/dense/dense_mapper.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

// 8 x 6 pinhole camera with f = 4: pixel (x, y) at depth d is at
// ((x - 4) d / 4, (y - 3) d / 4, d).
Camera SmallCamera() { return Camera{4, 4, 4, 3, 8, 6}; }

KeyframeInput FlatKeyframe(const Camera& c, float depth, uint8_t red) {
  KeyframeInput k;
  k.rgb = ImageU8(c.width, c.height, 3, 0);
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) k.rgb.at(x, y, 0) = red;
  k.depth = ImageF(c.width, c.height, 1, depth);
  return k;
}

DensePointOptions EveryPixel() {
  DensePointOptions o;
  o.stride = 1;
  o.mask_margin_px = 0;
  return o;
}

Rigid3d Pose(double angle_z, const Eigen::Vector3d& t) {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(angle_z, Eigen::Vector3d::UnitZ())), t);
}

TEST(DenseKeyframePoints, CountsEveryReasonAPixelIsLeftOut) {
  const Camera c = SmallCamera();
  KeyframeInput k = FlatKeyframe(c, 2.0f, 10);
  k.depth.at(0, 0) = std::numeric_limits<float>::quiet_NaN();
  k.depth.at(1, 0) = 0.0f;
  k.depth.at(2, 0) = std::numeric_limits<float>::infinity();
  k.depth.at(7, 5) = 9.0f;  // far, and an edge for its neighbours (6,5) and (7,4)
  k.dynamic_mask = ImageU8(c.width, c.height, 1, 0);
  k.dynamic_mask.at(4, 2) = 255;
  k.dynamic_mask.at(5, 2) = 255;
  const KeyframePoints p = ExtractKeyframePoints(c, k, EveryPixel(), 1e-3);
  EXPECT_EQ(p.no_depth, 3);
  EXPECT_EQ(p.out_of_range, 1);
  EXPECT_EQ(p.masked, 2);
  EXPECT_EQ(p.edge, 2);
  EXPECT_EQ(p.used, 48 - 8);
  ASSERT_EQ(p.size(), 40);  // a 1 mm cell per pixel: nothing merges
  // The first point is pixel (3, 0): ((3 - 4) 2 / 4, (0 - 3) 2 / 4, 2).
  EXPECT_FLOAT_EQ(p.xyz[0], -0.5f);
  EXPECT_FLOAT_EQ(p.xyz[1], -1.5f);
  EXPECT_FLOAT_EQ(p.xyz[2], 2.0f);
  for (float v : p.xyz) EXPECT_TRUE(std::isfinite(v));
}

TEST(DenseKeyframePoints, MaskMarginAndStride) {
  const Camera c = SmallCamera();
  KeyframeInput k = FlatKeyframe(c, 2.0f, 10);
  k.dynamic_mask = ImageU8(c.width, c.height, 1, 0);
  k.dynamic_mask.at(4, 2) = 255;
  DensePointOptions o = EveryPixel();
  o.mask_margin_px = 1;
  EXPECT_EQ(ExtractKeyframePoints(c, k, o, 1e-3).masked, 9);
  o.mask_margin_px = 0;
  o.stride = 2;
  const KeyframePoints p = ExtractKeyframePoints(c, k, o, 1e-3);
  EXPECT_EQ(p.masked + p.used, 12);  // the 4 x 3 grid of even pixels
  EXPECT_EQ(p.masked, 1);
}

TEST(DenseKeyframePoints, MergesPixelsOfOneCellWithMeanColour) {
  const Camera c = SmallCamera();
  KeyframeInput k = FlatKeyframe(c, 2.0f, 0);
  for (int y = 0; y < c.height; ++y) k.rgb.at(1, y, 0) = 101;
  // 10 m cells: every point lands in one of the cells of the octants.
  const KeyframePoints p = ExtractKeyframePoints(c, k, EveryPixel(), 10.0);
  int total = 0;
  for (uint32_t w : p.weight) total += w;
  EXPECT_EQ(total, 48);
  EXPECT_EQ(p.size(), 4);  // x < 0 or >= 0, y < 0 or >= 0 (z > 0)
  // Cell x < 0, y < 0: pixels x in 0..3, y in 0..2, of which 3 red.
  EXPECT_EQ(p.weight[0], 12u);
  EXPECT_EQ(p.rgb[0], 25);  // round(3 * 101 / 12)
}

TEST(DenseKeyframePoints, AllMaskedOrNoDepthGivesNoPoint) {
  const Camera c = SmallCamera();
  KeyframeInput k = FlatKeyframe(c, 2.0f, 10);
  k.dynamic_mask = ImageU8(c.width, c.height, 1, 1);
  KeyframePoints p = ExtractKeyframePoints(c, k, DensePointOptions(), 0.02);
  EXPECT_EQ(p.size(), 0);
  k.dynamic_mask = ImageU8();
  k.depth = ImageF();
  EXPECT_EQ(ExtractKeyframePoints(c, k, DensePointOptions(), 0.02).size(), 0);
}

TEST(DenseKeyframePoints, WrongSizesAndOptionsAreNamed) {
  const Camera c = SmallCamera();
  KeyframeInput k = FlatKeyframe(c, 2.0f, 10);
  k.depth = ImageF(4, 4, 1, 1.0f);
  EXPECT_THROW(
      {
        try {
          ExtractKeyframePoints(c, k, DensePointOptions(), 0.02);
        } catch (const InvalidInput& e) {
          EXPECT_NE(std::string(e.what()).find("depth is 4x4x1, expected 8x6x1"), std::string::npos) << e.what();
          throw;
        }
      },
      InvalidInput);
  DensePointOptions bad;
  bad.max_depth = 0.05f;
  std::string error;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(error.find("max_depth"), std::string::npos);
}

// Keyframe points at given camera-frame positions (weight 1).
KeyframePoints PointsAt(const std::vector<Eigen::Vector3d>& p, uint8_t red) {
  KeyframePoints k;
  for (const Eigen::Vector3d& v : p) {
    for (int a = 0; a < 3; ++a) {
      k.xyz.push_back(static_cast<float>(v[a]));
      k.rgb.push_back(a == 0 ? red : 0);
    }
    k.weight.push_back(1);
  }
  return k;
}

TEST(DenseVoxelMap, PoseUpdateMovesExactlyThatKeyframesPoints) {
  VoxelMapOptions o;
  o.voxel_size = 0.01;
  VoxelMap map(o);
  const std::vector<Eigen::Vector3d> cam_points = {{0.105, 0.2, 1.5}, {-0.3, 0.1, 2.25}, {0.5, -0.4, 3.0}};
  const Rigid3d a = Pose(0.3, {0.1, -0.2, 0.5});
  const Rigid3d other = Pose(-0.1, {2, 2, 2});
  map.AddKeyframe(4, a, PointsAt(cam_points, 200));
  map.AddKeyframe(9, other, PointsAt({{0.05, 0.05, 1.0}}, 50));
  auto expect_at = [&](const Rigid3d& pose) {
    const VoxelPoints vp = map.Points();
    ASSERT_EQ(vp.points.size(), 4);
    int found = 0;
    for (const Eigen::Vector3d& c : cam_points) {
      const Eigen::Vector3d w = pose.Inverse() * c;
      for (int i = 0; i < 4; ++i) {
        const Eigen::Vector3d q(vp.points.xyz[3 * i], vp.points.xyz[3 * i + 1], vp.points.xyz[3 * i + 2]);
        if ((q - w).norm() < 1e-5) {  // the 1e-5 m unit of the sums
          ++found;
          EXPECT_EQ(vp.points.rgb[3 * i], 200);
        }
      }
    }
    EXPECT_EQ(found, 3);
    // Keyframe 9's point did not move.
    const Eigen::Vector3d w9 = other.Inverse() * Eigen::Vector3d(0.05, 0.05, 1.0);
    bool still = false;
    for (int i = 0; i < 4; ++i)
      still |= (Eigen::Vector3d(vp.points.xyz[3 * i], vp.points.xyz[3 * i + 1], vp.points.xyz[3 * i + 2]) - w9)
                   .norm() < 1e-5;
    EXPECT_TRUE(still);
  };
  expect_at(a);
  const Rigid3d b = Pose(-1.2, {-3.0, 0.7, 0.25});
  map.SetKeyframePose(4, b);
  expect_at(b);
  EXPECT_EQ(map.stats().voxels, 4);
  EXPECT_EQ(map.stats().stored_points, 4);
}

TEST(DenseVoxelMap, ColourAveragesInACellAndSeparatesWhenMoved) {
  VoxelMapOptions o;
  o.voxel_size = 0.1;
  VoxelMap map(o);
  const Rigid3d identity;
  map.AddKeyframe(0, identity, PointsAt({{0.02, 0.02, 1.02}}, 100));
  map.AddKeyframe(1, identity, PointsAt({{0.04, 0.06, 1.08}}, 201));
  VoxelPoints vp = map.Points();
  ASSERT_EQ(vp.points.size(), 1);
  EXPECT_EQ(vp.points.rgb[0], 151);  // round(301 / 2)
  EXPECT_NEAR(vp.points.xyz[0], 0.03, 1e-6);
  EXPECT_NEAR(vp.points.xyz[1], 0.04, 1e-6);
  EXPECT_NEAR(vp.points.xyz[2], 1.05, 1e-6);
  EXPECT_EQ(map.Points(2).points.size(), 1);  // weight 2
  EXPECT_EQ(map.Points(3).points.size(), 0);
  map.SetKeyframePose(1, Pose(0, {-1, 0, 0}));  // keyframe 1's point moves to x = 1.04
  vp = map.Points();
  ASSERT_EQ(vp.points.size(), 2);
  EXPECT_EQ(vp.points.rgb[0], 100);  // ordered by cell: x index 0, then 10
  EXPECT_EQ(vp.points.rgb[3], 201);
  EXPECT_NEAR(vp.points.xyz[3], 1.04, 1e-6);
  map.RemoveKeyframe(0);
  EXPECT_EQ(map.Points().points.size(), 1);
  EXPECT_FALSE(map.HasKeyframe(0));
}

TEST(DenseVoxelMap, SameKeyframesAndPosesGiveTheSameMapInAnyOrder) {
  VoxelMapOptions o;
  o.voxel_size = 0.05;
  const std::vector<Eigen::Vector3d> p0 = {{0.1, 0.2, 1.0}, {0.11, 0.21, 1.01}, {0.4, 0.2, 1.3}};
  const std::vector<Eigen::Vector3d> p1 = {{0.12, 0.18, 1.02}, {-0.4, 0.0, 2.0}};
  const Rigid3d final0 = Pose(0.2, {0.01, 0.02, 0.03}), first1 = Pose(0.5, {1, 1, 1}), final1 = Pose(0.1, {0, 0, 0.1});
  VoxelMap a(o), b(o);
  a.AddKeyframe(0, Pose(0.9, {5, 5, 5}), PointsAt(p0, 10));
  a.AddKeyframe(1, first1, PointsAt(p1, 90));
  a.SetKeyframePose(0, final0);
  a.SetKeyframePose(1, final1);
  b.AddKeyframe(1, final1, PointsAt(p1, 90));
  b.AddKeyframe(0, final0, PointsAt(p0, 10));
  const VoxelPoints va = a.Points(), vb = b.Points();
  EXPECT_EQ(va.points.xyz, vb.points.xyz);
  EXPECT_EQ(va.points.rgb, vb.points.rgb);
  EXPECT_EQ(va.weight, vb.weight);
}

TEST(DenseVoxelMap, UnknownKeyframeAndBadPoseAreClearErrors) {
  VoxelMap map{VoxelMapOptions()};
  map.AddKeyframe(2, Rigid3d(), PointsAt({{0, 0, 1}}, 1));
  try {
    map.SetKeyframePose(7, Rigid3d());
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("no keyframe 7"), std::string::npos) << e.what();
  }
  EXPECT_THROW(map.AddKeyframe(2, Rigid3d(), PointsAt({{0, 0, 1}}, 1)), InvalidInput);
  Rigid3d nan_pose;
  nan_pose.translation.x() = std::nan("");
  EXPECT_THROW(map.SetKeyframePose(2, nan_pose), InvalidInput);
  EXPECT_EQ(map.Points().points.size(), 1);  // unchanged
}

TEST(DenseVoxelMap, MemoryIsBoundedByMaxVoxels) {
  VoxelMapOptions o;
  o.voxel_size = 0.01;
  o.max_voxels = 3;
  VoxelMap map(o);
  map.AddKeyframe(0, Rigid3d(), PointsAt({{0, 0, 1}, {0.1, 0, 1}, {0.2, 0, 1}, {0.3, 0, 1}, {0.4, 0, 1}}, 1));
  EXPECT_EQ(map.stats().voxels, 3);
  EXPECT_EQ(map.stats().dropped_points, 2);
  map.AddKeyframe(1, Rigid3d(), PointsAt({{0, 0, 1.001}}, 1));  // an existing cell: kept
  EXPECT_EQ(map.stats().dropped_points, 2);
  map.RemoveKeyframe(0);
  EXPECT_EQ(map.stats().voxels, 1);
  EXPECT_EQ(map.stats().dropped_points, 0);
}

TEST(DenseCloud, RemovesTheOutlierAndOrientsPlaneNormalsToTheCamera) {
  VoxelMapOptions o;
  o.voxel_size = 0.01;
  VoxelMap map(o);
  std::vector<Eigen::Vector3d> plane;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) plane.push_back({0.05 * i - 0.5, 0.05 * j - 0.5, 2.0});
  plane.push_back({0.0, 0.0, 1.0});  // 1 m in front of the plane
  map.AddKeyframe(0, Rigid3d(), PointsAt(plane, 1));  // camera at the origin looking along +z
  DenseCloudOptions c;
  const ColoredPoints cloud = DenseCloud(map, c);
  ASSERT_EQ(cloud.size(), 400);
  ASSERT_TRUE(cloud.has_normals());
  for (int i = 0; i < cloud.size(); ++i) {
    EXPECT_NEAR(cloud.xyz[3 * i + 2], 2.0, 1e-5);
    EXPECT_NEAR(cloud.normals[3 * i + 2], -1.0, 1e-4) << i;  // towards the camera
  }
  c.outlier_neighbors = 0;
  c.normal_neighbors = 0;
  const ColoredPoints raw = DenseCloud(map, c);
  EXPECT_EQ(raw.size(), 401);
  EXPECT_FALSE(raw.has_normals());
}

TEST(DenseMapper, ThreadedAndSynchronousGiveTheSameCloud) {
  const Camera c = SmallCamera();
  DenseMapOptions o;
  o.points = EveryPixel();
  o.map.voxel_size = 0.05;
  DenseMapper threaded(c, o, false), sync(c, o, true);
  for (int id = 0; id < 6; ++id) {
    KeyframeInput k = FlatKeyframe(c, 1.0f + 0.25f * id, static_cast<uint8_t>(40 * id));
    k.cam_from_world = Pose(0.1 * id, {0.02 * id, 0, 0});
    threaded.Add(id, k);
    sync.Add(id, k);
  }
  threaded.SetPose(3, Pose(0.4, {0, 0.3, 0}));
  sync.SetPose(3, Pose(0.4, {0, 0.3, 0}));
  const ColoredPoints a = threaded.Cloud(), b = sync.Cloud();
  EXPECT_GT(a.size(), 50);
  EXPECT_EQ(a.xyz, b.xyz);
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(threaded.stats().pose_updates, 1);
}

TEST(DenseMapper, BadInputIsRefusedOnTheCallersThread) {
  const Camera c = SmallCamera();
  DenseMapper dense(c, DenseMapOptions(), false);
  KeyframeInput k = FlatKeyframe(c, 2.0f, 10);
  k.dynamic_mask = ImageU8(c.width, c.height, 1, 255);  // all masked: added, no points
  dense.Add(0, k);
  EXPECT_THROW(dense.Add(0, k), InvalidInput);
  try {
    dense.SetPose(5, Rigid3d());
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("no keyframe 5"), std::string::npos) << e.what();
  }
  k.rgb = ImageU8(3, 3, 3);
  EXPECT_THROW(dense.Add(1, k), InvalidInput);
  const DenseMapStats s = dense.stats();
  EXPECT_EQ(s.keyframes_added, 1);
  EXPECT_EQ(s.empty_keyframes, 1);
  EXPECT_EQ(dense.Cloud().size(), 0);
  // An empty cloud is still a valid PLY with 0 vertices.
  const std::string path = testing::TestTempDir() + "/dense.ply";
  dense.Save(path);
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "ply");
}

}  // namespace
}  // namespace dypho
