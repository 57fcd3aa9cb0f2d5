// ApplyKeyframeCorrections: corrections reach the engine keyframes made
// from their frames; a frame the engine never took is skipped.
#include <gtest/gtest.h>

#include <map>
#include <vector>

#include "engine/pipeline/loop_response.h"

namespace dypho {
namespace {

TEST(LoopResponse, CorrectionWithoutEngineKeyframeIsSkipped) {
  const Rigid3d a(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1, 0.0, 0.0));
  const Rigid3d b(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.2, 0.0));
  const Rigid3d c(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, 0.3));
  // Frames 3, 7 and 9 corrected; the engine made keyframe 0 from frame 3
  // and keyframe 1 from frame 9 (frame 7 was never an engine keyframe).
  const std::vector<PoseCorrection> corrections = {{3, a}, {7, b}, {9, c}};
  const std::map<long, int> engine_keyframes = {{3, 0}, {9, 1}, {12, 2}};
  std::map<int, Rigid3d> updated;
  int skipped = -1;
  const int moved = ApplyKeyframeCorrections(
      corrections, engine_keyframes, [&](int id, const Rigid3d& pose) { updated[id] = pose; }, &skipped);
  EXPECT_EQ(moved, 2);
  EXPECT_EQ(skipped, 1);
  ASSERT_EQ(updated.size(), 2u);
  EXPECT_EQ(updated.at(0).translation, a.translation);
  EXPECT_EQ(updated.at(1).translation, c.translation);
  EXPECT_EQ(updated.count(2), 0u);  // no correction for frame 12: keyframe 2 untouched
}

}  // namespace
}  // namespace dypho
