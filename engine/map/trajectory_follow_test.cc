// KeyframeFollow on trajectories with known answers: a frame at a refined
// keyframe takes the keyframe's refined pose exactly, a frame between two
// keyframes the interpolated correction, frames outside the keyframes' span
// the nearest keyframe's; unmoved keyframes change nothing.
#include "engine/map/trajectory_follow.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/check.h"

namespace dypho {
namespace {

Rigid3d Pose(double t) {  // a camera turning and moving along x
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * t, Eigen::Vector3d(0.2, 1, 0.1).normalized())),
                 Eigen::Vector3d(0.5 * t, 0.1 * std::sin(t), 1.0));
}

Trajectory Frames() {  // 0.0, 0.1, ..., 1.0 s
  Trajectory t;
  for (int i = 0; i <= 10; ++i) t.Add(0.1 * i, Pose(0.1 * i));
  return t;
}

Rigid3d Turn(double deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& shift) {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(deg * M_PI / 180.0, axis.normalized())), shift);
}

void ExpectNear(const Rigid3d& a, const Rigid3d& b, double tol = 1e-12) {
  EXPECT_LT((a.translation - b.translation).norm(), tol);
  EXPECT_LT(RotationAngle(a.rotation, b.rotation), tol);
}

TEST(KeyframeFollow, FramesFollowTheRefinedKeyframesWithKnownAnswers) {
  const Trajectory frames = Frames();
  // Keyframes at 0.2 s and 0.6 s (0.2 s given as 0.20004 s: within the
  // tolerance), refined on the world side by two known corrections; a third
  // keyframe at 0.35 s is in no frame's line and is left out.
  const Rigid3d ca = Turn(0.5, {0, 1, 0}, {0.01, 0, 0});
  const Rigid3d cb = Turn(-0.8, {1, 0, 0.3}, {0, -0.02, 0.005});
  Trajectory keyframes;
  keyframes.Add(0.20004, ca * Pose(0.2));
  keyframes.Add(0.35, Turn(5, {0, 0, 1}, {1, 1, 1}) * Pose(0.35));
  keyframes.Add(0.6, cb * Pose(0.6));
  const KeyframeFollow follow(frames, keyframes);
  EXPECT_EQ(follow.stats().keyframes, 2);
  const Trajectory out = follow.Apply(frames);
  ASSERT_EQ(out.size(), frames.size());
  for (size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out.timestamps[i], frames.timestamps[i]);
    const double t = frames.timestamps[i];
    Rigid3d c = ca;  // at and before the first keyframe
    if (t > 0.6 - 1e-9) c = cb;  // at and after the last
    else if (t > 0.2 + 1e-9) c = Interpolate(ca, cb, (t - 0.2) / 0.4);
    ExpectNear(out.world_from_cam[i], c * frames.world_from_cam[i]);
  }
  // The keyframes' own lines are their refined poses.
  ExpectNear(out.world_from_cam[2], keyframes.world_from_cam[0]);
  ExpectNear(out.world_from_cam[6], keyframes.world_from_cam[2]);
  // A camera pose (cam_from_world) moves the same way.
  ExpectNear(follow.MoveCamFromWorld(0.4, frames.world_from_cam[4].Inverse()), out.world_from_cam[4].Inverse());
  // Halfway, the rotation correction is half of each: the slerp midpoint.
  const Rigid3d mid = follow.CorrectionAt(0.4);
  EXPECT_NEAR(RotationAngle(mid.rotation, ca.rotation), RotationAngle(mid.rotation, cb.rotation), 1e-12);
  // Stats: how far the two keyframes moved.
  const double moved_a = ((ca * Pose(0.2)).translation - Pose(0.2).translation).norm();
  const double moved_b = ((cb * Pose(0.6)).translation - Pose(0.6).translation).norm();
  EXPECT_NEAR(follow.stats().max_translation, std::max(moved_a, moved_b), 1e-12);
  EXPECT_NEAR(follow.stats().mean_translation, 0.5 * (moved_a + moved_b), 1e-12);
  EXPECT_NEAR(follow.stats().max_rotation_deg, 0.8, 1e-9);
  EXPECT_NEAR(follow.stats().mean_rotation_deg, 0.65, 1e-9);
}

TEST(KeyframeFollow, UnmovedKeyframesOrNoneChangeNothing) {
  const Trajectory frames = Frames();
  Trajectory same;
  same.Add(0.3, Pose(0.3));
  same.Add(0.9, Pose(0.9));
  for (const Trajectory& keyframes : {same, Trajectory()}) {
    const KeyframeFollow follow(frames, keyframes);
    const Trajectory out = follow.Apply(frames);
    for (size_t i = 0; i < out.size(); ++i) ExpectNear(out.world_from_cam[i], frames.world_from_cam[i], 1e-14);
    EXPECT_LT(follow.stats().max_translation, 1e-14);
  }
}

TEST(KeyframeFollow, ATrajectoryWithoutItsPosesIsAnError) {
  Trajectory broken = Frames();
  broken.world_from_cam.pop_back();
  EXPECT_THROW(KeyframeFollow(broken, Frames()), InvalidInput);
  EXPECT_THROW(KeyframeFollow(Frames(), broken), InvalidInput);
}

}  // namespace
}  // namespace dypho
