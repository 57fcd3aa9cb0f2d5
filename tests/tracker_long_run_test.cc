// Bounded map on revisited ground: the ORB tracker with local BA, culling
// and loops over the synthetic loop replayed lap after lap
// (tests/long_loop_run.h). After the first lap, the laps revisit mapped
// ground: the live keyframes and map points stop growing (keyframes made
// there are culled as redundant, their points culled or fused).
#include <gtest/gtest.h>

#include "tests/long_loop_run.h"

namespace dypho {
namespace {

TEST(TrackerLongRun, KeyframesStopGrowingOnRevisitedGround) {
  OrbTrackerOptions o;
  o.local_ba.threaded = false;  // deterministic
  const int laps = 5;
  const testing::LongRun run = testing::TrackRepeatedLoop(laps * testing::kLongRunLapFrames, o);
  testing::PrintLongRun(run);
  ASSERT_EQ(run.laps.size(), static_cast<size_t>(laps));
  EXPECT_EQ(run.tracked, laps * testing::kLongRunLapFrames);
  EXPECT_GE(run.stats.loops.size(), 1u);
  // Measured (live keyframes / made / culled / live points after each lap):
  // 14/14/0/7715, 20/20/0/7597, 26/26/0/7487, 30/32/2/7486, 30/38/8/7440;
  // over 3000 frames (tests/bench/long_run_bench.cc) the live keyframes stay
  // at 30 while 108 are made.
  const testing::LongRunSample& second = run.laps[1];
  const testing::LongRunSample& fourth = run.laps[3];
  const testing::LongRunSample& last = run.laps.back();
  // Keyframes keep being made on the revisits (one every
  // keyframe_max_frames at least) ...
  EXPECT_GE(last.keyframes - fourth.keyframes, 4);
  // ... and as many are culled as redundant: the live count stops growing.
  EXPECT_EQ(last.culled_keyframes - fourth.culled_keyframes, last.keyframes - fourth.keyframes);
  EXPECT_LE(last.live_keyframes, fourth.live_keyframes);
  EXPECT_LE(last.live_keyframes, 40);
  // Map points do not grow after the first lap.
  EXPECT_LE(last.live_points, second.live_points);
}

}  // namespace
}  // namespace dypho
