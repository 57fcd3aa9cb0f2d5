// SparseMap: observations, culling and the reuse of released point slots.
#include "tracker/backend/sparse_map.h"

#include <gtest/gtest.h>

namespace dypho {
namespace {

// Two keyframes with three features each; point p is seen by feature p of
// both.
SparseMap TwoKeyframesThreePoints() {
  SparseMap map;
  for (int k = 0; k < 2; ++k) {
    Keyframe kf;
    kf.map_points.assign(3, -1);
    map.keyframes.push_back(kf);
    ++map.live_keyframes;
  }
  for (int p = 0; p < 3; ++p) {
    MapPoint mp;
    mp.position = Eigen::Vector3d(p, 0, 1);
    const long id = map.NewPoint(mp);
    EXPECT_EQ(id, p);
    ++map.live_points;
    map.AddObservation(id, 0, p);
    map.AddObservation(id, 1, p);
  }
  return map;
}

TEST(SparseMap, NewPointAppendsWhenNoSlotIsReleased) {
  SparseMap map = TwoKeyframesThreePoints();
  EXPECT_EQ(map.points.size(), 3u);
  map.SetPointBad(1);  // bad, but not released: its slot is not reused yet
  MapPoint mp;
  EXPECT_EQ(map.NewPoint(mp), 3);
  EXPECT_EQ(map.points.size(), 4u);
}

TEST(SparseMap, ReleasedSlotIsReusedAndTheOldObservationsAreGone) {
  SparseMap map = TwoKeyframesThreePoints();
  // Culled the tracker's way: bad, the observations left in place.
  map.points[1].bad = true;
  --map.live_points;
  ASSERT_EQ(map.keyframes[0].map_points[1], 1);
  EXPECT_EQ(map.ReleaseBadPoints(), 1);
  EXPECT_EQ(map.keyframes[0].map_points[1], -1);
  EXPECT_EQ(map.keyframes[1].map_points[1], -1);
  EXPECT_TRUE(map.points[1].released);
  EXPECT_TRUE(map.points[1].keyframes.empty());
  EXPECT_EQ(map.ReleaseBadPoints(), 0);  // released once only

  MapPoint fresh;
  fresh.position = Eigen::Vector3d(7, 8, 9);
  fresh.keyframes = {1};
  fresh.features = {1};
  const long id = map.NewPoint(fresh);
  EXPECT_EQ(id, 1);
  EXPECT_EQ(map.points.size(), 3u);
  EXPECT_FALSE(map.points[1].bad);
  EXPECT_FALSE(map.points[1].released);
  EXPECT_EQ(map.points[1].position, Eigen::Vector3d(7, 8, 9));
  // The others are untouched.
  EXPECT_EQ(map.keyframes[0].map_points[0], 0);
  EXPECT_EQ(map.keyframes[1].map_points[2], 2);
  EXPECT_EQ(map.points[2].keyframes.size(), 2u);
  // No slot left: the next point goes at the end.
  EXPECT_EQ(map.NewPoint(MapPoint()), 3);
}

TEST(SparseMap, PointsOfACulledKeyframeAreReleasedWhenLeftUnobserved) {
  SparseMap map = TwoKeyframesThreePoints();
  map.EraseObservation(1, 2);  // point 2 only in keyframe 0 now
  map.SetKeyframeBad(0);       // point 2 loses its last observation
  EXPECT_TRUE(map.points[2].bad);
  EXPECT_FALSE(map.points[0].bad);
  EXPECT_EQ(map.live_points, 2);
  EXPECT_EQ(map.ReleaseBadPoints(), 1);
  EXPECT_EQ(map.free_points, std::vector<long>{2});
  map.Clear();
  EXPECT_TRUE(map.free_points.empty());
  EXPECT_EQ(map.NewPoint(MapPoint()), 0);
}

}  // namespace
}  // namespace dypho
