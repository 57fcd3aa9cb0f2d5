#include "engine/eval/kitti_error.h"

#include <gtest/gtest.h>

#include "common/check.h"

namespace dypho {
namespace {

TEST(KittiError, ScaledStraightPathGivesItsScaleError) {
  Trajectory gt, est;
  for (int i = 0; i <= 20; ++i) {
    gt.Add(i, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, i)));      // 1 m a frame along z
    est.Add(i, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 1.02 * i)));  // 2 % too long
  }
  const KittiError e = ComputeKittiError(gt, est, {5, 10, 30});
  EXPECT_EQ(e.segments, 16 + 11);  // first frames 0..15 for 5 m, 0..10 for 10 m, none for 30 m
  EXPECT_NEAR(e.translation_percent, 2.0, 1e-9);
  EXPECT_NEAR(e.rotation_deg_per_m, 0.0, 1e-9);
  EXPECT_NEAR(ComputeKittiError(gt, gt, {5}).translation_percent, 0.0, 1e-12);
  est.world_from_cam.pop_back(), est.timestamps.pop_back();
  EXPECT_THROW(ComputeKittiError(gt, est, {5}), InvalidInput);
}

}  // namespace
}  // namespace dypho
