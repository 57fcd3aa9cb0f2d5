// LiveReplay on a simulated clock: which frames a live camera hands over to
// a tracking thread of known speed, counted exactly.
#include "engine/pipeline/live_replay.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "tests/test_data.h"

namespace dypho {
namespace {

// `n` frames at `rate` Hz replayed at `speed`, each processed frame taking
// `busy` seconds of simulated time; returns the processed positions.
std::vector<long> Replay(int n, double rate, double speed, double busy, long* dropped) {
  std::vector<double> timestamps;
  for (int i = 0; i < n; ++i) timestamps.push_back(1000.0 + i / rate);
  double now = 5.0;
  LiveReplay replay(timestamps, speed, [&] { return now; }, [&](double t) { now = std::max(now, t); });
  std::vector<long> processed;
  for (long k = replay.Next(-1); k >= 0; k = replay.Next(k)) {
    processed.push_back(k);
    now += busy;
  }
  *dropped = replay.dropped();
  return processed;
}

TEST(LiveReplay, ASlowTrackerGetsTheNewestFrameAndDropsOnlyTheOnesBefore) {
  // 31 frames at 30 Hz, 46 ms a frame (1.38 frame periods): the m-th
  // processed frame is the newest arrived at m * 46 ms, floor(1.38 m),
  // until frame 30 (m = 22): 23 processed, 8 dropped.
  long dropped = 0;
  const std::vector<long> processed = Replay(31, 30.0, 1.0, 0.046, &dropped);
  ASSERT_EQ(processed.size(), 23u);
  EXPECT_EQ(dropped, 8);
  for (size_t m = 0; m + 1 < processed.size(); ++m)
    EXPECT_EQ(processed[m], static_cast<long>(1.38 * m)) << "processed frame " << m;
  EXPECT_EQ(processed.back(), 30);
}

TEST(LiveReplay, AFastTrackerOrASlowReplayDropsNothing) {
  long dropped = 0;
  // 20 ms a frame at 30 Hz: it waits for every frame.
  std::vector<long> processed = Replay(31, 30.0, 1.0, 0.020, &dropped);
  EXPECT_EQ(processed.size(), 31u);
  EXPECT_EQ(dropped, 0);
  // 46 ms a frame at half speed (a frame every 66.7 ms): none dropped.
  processed = Replay(31, 30.0, 0.5, 0.046, &dropped);
  EXPECT_EQ(processed.size(), 31u);
  EXPECT_EQ(dropped, 0);
  // Twice as fast as the slow tracker at half speed is the same as at full speed.
  processed = Replay(31, 30.0, 0.5, 0.092, &dropped);
  EXPECT_EQ(processed.size(), 23u);
  EXPECT_EQ(dropped, 8);
}

TEST(LiveReplay, WaitsForAFrameThatHasNotArrived) {
  double now = 0.0;
  std::vector<double> slept;
  LiveReplay replay({0.0, 0.5, 1.0}, 1.0, [&] { return now; }, [&](double t) {
    slept.push_back(t);
    now = std::max(now, t);
  });
  EXPECT_EQ(replay.Next(-1), 0);
  now += 0.1;
  EXPECT_EQ(replay.Next(0), 1);  // arrives at 0.5: waited for
  ASSERT_EQ(slept.size(), 1u);
  EXPECT_DOUBLE_EQ(slept[0], 0.5);
  now += 0.7;                    // 1.2: frame 2 arrived at 1.0
  EXPECT_EQ(replay.Next(1), 2);
  EXPECT_EQ(replay.Next(2), -1);
  EXPECT_EQ(replay.dropped(), 0);
}

TEST(LiveReplay, RejectsDecreasingTimestampsAndABadSpeed) {
  EXPECT_INVALID_INPUT(LiveReplay({0.0, 0.2, 0.1}, 1.0), "must not decrease");
  EXPECT_INVALID_INPUT(LiveReplay({0.0, 0.1}, 0.0), "realtime_speed");
}

}  // namespace
}  // namespace dypho
