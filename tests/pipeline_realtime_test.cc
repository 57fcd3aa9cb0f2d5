// `dypho run --realtime` on real TUM frames (30 Hz): a tracking thread
// slowed to 200 ms a frame drops frames, at least as many as its speed
// forces, and every frame is either processed or counted as dropped; a
// replay slow enough for it drops none. (The exact counts for a known
// speed are checked on a simulated clock in live_replay_test.)
#include <gtest/gtest.h>

#include <cmath>

#include "engine/pipeline/pipeline.h"
#include "tests/pipeline_test_options.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

PipelineOptions Options() {
  PipelineOptions o = PresetOptions("tum");
  o.poses = "gt";
  o.realtime = true;
  o.masking.use_background = false;
  o.iterations_per_keyframe = 5;
  o.mapper.train_downscale = 4;
  o.final_iterations = 0;
  testing::SkipExtraOutputs(&o);
  return o;
}

TEST(PipelineRealtime, ASlowTrackerDropsFramesAndASlowReplayDropsNone) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  const auto dataset = OpenDataset(testing::SharedData("tum_fr1_rpy_head250"));
  PipelineHooks quiet;
  quiet.show_progress = false;
  const std::string dir = testing::TestTempDir();

  PipelineOptions slow = Options();
  slow.max_frames = 20;
  slow.debug_track_delay_ms = 200;
  const PipelineResult r = RunPipeline(slow, *dataset, dir + "/slow", quiet);
  const double span = dataset->info(19).timestamp - dataset->info(0).timestamp;
  // Each processed frame takes >= 0.2 s: at most floor(span / 0.2) + 2 of them.
  const long must_drop = 20 - static_cast<long>(std::floor(span / 0.2)) - 2;
  std::printf("20 frames over %.3f s, 200 ms a frame: %ld processed, %ld dropped (at least %ld must be)\n", span,
              r.frames, r.dropped_frames, must_drop);
  EXPECT_GE(r.dropped_frames, must_drop);
  EXPECT_EQ(r.frames + r.dropped_frames, 20);
  EXPECT_NE(r.mode.find("realtime"), std::string::npos);

  PipelineOptions gentle = Options();
  gentle.max_frames = 8;
  gentle.realtime_speed = 0.05;  // a frame every 0.67 s
  const PipelineResult g = RunPipeline(gentle, *dataset, dir + "/gentle", quiet);
  EXPECT_EQ(g.dropped_frames, 0);
  EXPECT_EQ(g.frames, 8);
}

}  // namespace
}  // namespace dypho
