// The seen-through test on exact depth: a wall 3 m away and a board 1.5 m
// away, seen by cameras that move sideways. A board that is gone in the
// other frames is found pixel for pixel; a board that stays is not.
#include "engine/dynamic/seen_through.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <optional>

#include "common/check.h"

namespace dypho {
namespace {

Camera TestCamera() { return Camera{200, 200, 79.5, 59.5, 160, 120}; }

struct Board {
  double x0, x1, y0, y1, z;  // world rectangle at depth z
};

// Exact depth of a camera at `world_x` (looking along world +z) seeing a
// wall at z = 3 and, when given, a board.
ImageF Render(const Camera& c, double world_x, const std::optional<Board>& board) {
  ImageF d(c.width, c.height, 1, 0.0f);
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const double a = (x - c.cx) / c.fx, b = (y - c.cy) / c.fy;
      double z = 3.0;
      if (board) {
        const double wx = world_x + a * board->z, wy = b * board->z;
        if (wx >= board->x0 && wx < board->x1 && wy >= board->y0 && wy < board->y1) z = board->z;
      }
      d.at(x, y) = static_cast<float>(z);
    }
  return d;
}

Rigid3d CameraAt(double world_x) {
  return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-world_x, 0, 0));  // cam_from_world
}

SeenThroughOptions ExactOptions() {
  SeenThroughOptions o;
  o.enabled = true;
  o.window = 4;
  o.neighbours = 8;
  o.votes = 3;
  o.dilate = 0;
  return o;
}

const Board kBoard{-0.2, 0.2, -0.15, 0.25, 1.5};

TEST(SeenThrough, FindsTheBoardThatIsGoneExactly) {
  const Camera c = TestCamera();
  const ImageF key = Render(c, 0.0, kBoard);
  std::vector<DepthAtPose> others;
  for (double x : {-0.12, -0.06, 0.06, 0.12})
    others.push_back({MinPoolDepth(Render(c, x, std::nullopt), 4), CameraAt(x)});
  std::vector<const DepthAtPose*> ptrs;
  for (const DepthAtPose& o : others) ptrs.push_back(&o);
  const ImageU8 mask = SeenThroughMask(c, key, CameraAt(0.0), ptrs, ExactOptions());
  int board = 0, wrong = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const bool on_board = key.at(x, y) < 2.0f;
      board += on_board;
      wrong += (mask.at(x, y) != 0) != on_board;
    }
  EXPECT_GT(board, 1000);
  EXPECT_EQ(wrong, 0);
}

TEST(SeenThrough, KeepsTheBoardThatStays) {
  const Camera c = TestCamera();
  const ImageF key = Render(c, 0.0, kBoard);
  std::vector<DepthAtPose> others;
  for (double x : {-0.12, -0.06, 0.06, 0.12}) {
    // Each neighbour's depth pooled with its 3x3 blocks, as the queue keeps it.
    others.push_back({MinPoolDepth(Render(c, x, kBoard), 4), CameraAt(x)});
  }
  std::vector<const DepthAtPose*> ptrs;
  for (const DepthAtPose& o : others) ptrs.push_back(&o);
  int masked = 0;
  const ImageU8 mask = SeenThroughMask(c, key, CameraAt(0.0), ptrs, ExactOptions());
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) masked += mask.at(x, y) != 0;
  EXPECT_EQ(masked, 0);
}

TEST(SeenThrough, TooFewVotesMaskNothing) {
  const Camera c = TestCamera();
  const ImageF key = Render(c, 0.0, kBoard);
  std::vector<DepthAtPose> others;
  for (double x : {-0.06, 0.06}) others.push_back({MinPoolDepth(Render(c, x, std::nullopt), 4), CameraAt(x)});
  std::vector<const DepthAtPose*> ptrs{&others[0], &others[1]};
  const ImageU8 mask = SeenThroughMask(c, key, CameraAt(0.0), ptrs, ExactOptions());
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) ASSERT_EQ(mask.at(x, y), 0) << x << "," << y;
}

TEST(SeenThrough, MinPoolKeepsTheNearestValidDepth) {
  ImageF d(5, 3, 1, 0.0f);
  d.at(0, 0) = 2.0f;
  d.at(1, 1) = 1.0f;
  d.at(4, 2) = 3.0f;
  d.at(3, 2) = std::numeric_limits<float>::quiet_NaN();
  const ImageF p = MinPoolDepth(d, 2);
  ASSERT_EQ(p.width(), 3);
  ASSERT_EQ(p.height(), 2);
  EXPECT_EQ(p.at(0, 0), 1.0f);
  EXPECT_EQ(p.at(1, 0), 0.0f);
  EXPECT_EQ(p.at(2, 1), 3.0f);
  EXPECT_EQ(p.at(1, 1), 0.0f);  // NaN is no depth
}

// The queue holds a keyframe until `window` frames after it have come, tests
// it against frames on both sides, and keeps its corrected pose apart.
TEST(SeenThroughQueue, HoldsForTheWindowThenMasks) {
  const Camera c = TestCamera();
  SeenThroughOptions o = ExactOptions();
  SeenThroughQueue q(c, o);
  const std::vector<double> xs{-0.12, -0.09, -0.06, -0.03, 0.0, 0.03, 0.06, 0.09, 0.12};
  for (size_t i = 0; i < xs.size(); ++i) {
    const bool key = i == 4;
    const long long index = q.Add(Render(c, xs[i], key ? std::optional<Board>(kBoard) : std::nullopt), CameraAt(xs[i]));
    ASSERT_EQ(index, static_cast<long long>(i));
    if (key) {
      KeyframeInput in;
      in.depth = Render(c, 0.0, kBoard);
      in.cam_from_world = CameraAt(0.0);
      q.Hold(7, std::move(in), index);
      Rigid3d moved = CameraAt(0.01);
      ASSERT_TRUE(q.SetPose(7, moved));
      EXPECT_FALSE(q.SetPose(8, moved));
    }
    const auto out = q.Release(false);
    if (i < 8) {
      EXPECT_TRUE(out.empty()) << "released after frame " << i;
      continue;
    }
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].first, 7);
    const KeyframeInput& in = out[0].second;
    EXPECT_NEAR(in.cam_from_world.translation.x(), -0.01, 1e-12);  // the correction, for mapping
    int wrong = 0, board = 0;
    for (int y = 0; y < c.height; ++y)
      for (int x = 0; x < c.width; ++x) {
        const bool on_board = in.depth.at(x, y) < 2.0f;
        board += on_board;
        wrong += (in.dynamic_mask.at(x, y) != 0) != on_board;
      }
    EXPECT_EQ(wrong, 0);
    EXPECT_EQ(q.masked_pixels(), board);
    EXPECT_EQ(q.held(), 0);
  }
}

TEST(SeenThroughQueue, ReleasesEverythingAtTheEnd) {
  const Camera c = TestCamera();
  SeenThroughQueue q(c, ExactOptions());
  for (int i = 0; i < 3; ++i) {
    const long long index = q.Add(Render(c, 0.03 * i, std::nullopt), CameraAt(0.03 * i));
    KeyframeInput in;
    in.depth = Render(c, 0.03 * i, std::nullopt);
    in.cam_from_world = CameraAt(0.03 * i);
    q.Hold(i, std::move(in), index);
  }
  EXPECT_TRUE(q.Release(false).empty());
  const auto out = q.Release(true);
  ASSERT_EQ(out.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(out[i].first, i);
  EXPECT_EQ(q.masked_pixels(), 0);  // a static wall stays static
}

// A board that stays, with the neighbours' poses 6 cm off sideways (8 px
// at the board): its edge pixels land on the wall behind in the neighbours'
// depth unless edge_blocks takes the nearest depth over the error.
int MaskedWithPoseError(int edge_blocks) {
  const Camera c = TestCamera();
  SeenThroughOptions o = ExactOptions();
  o.edge_blocks = edge_blocks;
  SeenThroughQueue q(c, o);
  for (int i = -4; i <= 4; ++i) {
    const double x = 0.03 * i;
    const long long index = q.Add(Render(c, x, kBoard), CameraAt(i == 0 ? x : x + 0.06));
    if (i == 0) {
      KeyframeInput in;
      in.depth = Render(c, x, kBoard);
      in.cam_from_world = CameraAt(x);
      q.Hold(0, std::move(in), index);
    }
  }
  const auto out = q.Release(true);
  EXPECT_EQ(out.size(), 1u);
  return static_cast<int>(q.masked_pixels());
}

TEST(SeenThroughQueue, EdgeBlocksAbsorbAPoseErrorAtDepthEdges) {
  const int strict = MaskedWithPoseError(0), tolerant = MaskedWithPoseError(3);
  std::printf("board that stays, neighbours 8 px off: %d pixels masked with edge_blocks 0, %d with 3\n", strict, tolerant);
  EXPECT_GT(strict, 50);
  EXPECT_EQ(tolerant, 0);
}

// Exact depth of a rolling-shutter camera: row v is seen by
// Exp(omega tau(v)) cam_from_world (engine/map/sensor_model.h), the wall at
// z = 3 and the board at its depth.
ImageF RenderRolling(const Camera& c, const Rigid3d& cam_from_world, const Eigen::Vector3d& omega, double readout) {
  ImageF d(c.width, c.height, 1, 0.0f);
  for (int y = 0; y < c.height; ++y) {
    const double tau = readout * (static_cast<double>(y) / (c.height - 1) - 0.5);
    const Eigen::Vector3d w = omega * tau;
    const Eigen::Quaterniond q(Eigen::AngleAxisd(w.norm(), w.norm() > 0 ? w.normalized() : Eigen::Vector3d::UnitZ()));
    const Rigid3d row = Rigid3d(q, Eigen::Vector3d::Zero()) * cam_from_world;
    const Eigen::Matrix3d r = row.rotation.toRotationMatrix();
    const Eigen::Vector3d centre = -(r.transpose() * row.translation);
    for (int x = 0; x < c.width; ++x) {
      const Eigen::Vector3d ray((x - c.cx) / c.fx, (y - c.cy) / c.fy, 1.0);  // camera z = 1
      const Eigen::Vector3d dir = r.transpose() * ray;
      double depth = (3.0 - centre.z()) / dir.z();
      const double tb = (kBoard.z - centre.z()) / dir.z();
      const Eigen::Vector3d hit = centre + tb * dir;
      if (hit.x() >= kBoard.x0 && hit.x() < kBoard.x1 && hit.y() >= kBoard.y0 && hit.y() < kBoard.y1) depth = tb;
      d.at(x, y) = static_cast<float>(depth);
    }
  }
  return d;
}

// A board that stays, seen by a camera pitching at 3 rad/s with a 60 ms
// rolling shutter (exaggerated, so that the block pooling does not absorb
// it): the rows' shear makes the board's edges land on the wall in the
// neighbours unless the test models it (readout); edge_blocks 0 and one
// vote so that nothing else absorbs it.
int MaskedWhileTurning(double modelled_readout) {
  const Camera c = TestCamera();
  SeenThroughOptions o = ExactOptions();
  o.edge_blocks = 0;
  o.votes = 1;  // any neighbour that sees through counts
  o.readout = modelled_readout;
  SeenThroughQueue q(c, o);
  const Eigen::Vector3d omega(3.0, 0.0, 0.0);
  for (int i = -4; i <= 4; ++i) {
    const double t = 0.033 * i;
    const Rigid3d pose(Eigen::Quaterniond(Eigen::AngleAxisd(omega.x() * t, Eigen::Vector3d::UnitX())),
                       Eigen::Vector3d::Zero());
    const ImageF depth = RenderRolling(c, pose, omega, 0.06);
    const long long index = q.Add(depth, pose, omega);
    if (i == 0) {
      KeyframeInput in;
      in.depth = depth;
      in.cam_from_world = pose;
      in.angular_velocity = omega;
      q.Hold(0, std::move(in), index);
    }
  }
  EXPECT_EQ(q.Release(true).size(), 1u);
  return static_cast<int>(q.masked_pixels());
}

TEST(SeenThroughQueue, RollingShutterModelKeepsABoardThatStays) {
  const int global = MaskedWhileTurning(0.0), rolling = MaskedWhileTurning(0.06);
  std::printf("board that stays, camera pitching at 3 rad/s, 60 ms readout: %d pixels masked as global shutter, %d modelled\n",
              global, rolling);
  EXPECT_GT(global, 30);
  EXPECT_EQ(rolling, 0);
}

TEST(SeenThrough, BadOptionsNameTheField) {
  SeenThroughOptions o = ExactOptions();
  o.votes = 0;
  try {
    o.Validate();
    FAIL() << "votes 0 accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("seen_through.votes"), std::string::npos) << e.what();
  }
  o = ExactOptions();
  o.edge_blocks = -1;
  EXPECT_THROW(o.Validate(), InvalidInput);
}

}  // namespace
}  // namespace dypho
