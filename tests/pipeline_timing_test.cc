// Results independent of timing: the walkers version of TUM fr1/rpy (three
// people composited by ../shared/tools/walkers; frames 0-59 of head250) in
// threaded mode, once as it comes and once with the detector thread slowed
// by 150 ms a run, and in sequential mode, with each of the two detector
// schedules: looking ahead (detector_look_ahead, the default for recorded
// RGB-D) and the fixed lag of max_mask_age (realtime, stereo). The fixed
// ages (the detector's, tracker.local_ba.fixed_lag, tracker.loops.fixed_lag)
// hold in all three (the
// sequential run computes the detector's masks, the local BA and the loop
// query on the tracking thread and uses them as late as the threaded run
// does), so the three trajectories are the same. The background model's
// prior comes from earlier frames (background_prior = frames): what the
// map's renders show depends on the mapping thread's progress (not fixed).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "engine/pipeline/pipeline.h"
#include "tests/pipeline_test_options.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class PipelineTiming : public ::testing::TestWithParam<int> {};  // detector_look_ahead

TEST_P(PipelineTiming, ThreadedRunWithASlowDetectorGivesTheSameTrajectoryAsAFastOne) {
  const int look_ahead = GetParam();
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  DYPHO_REQUIRE_SHARED_DATA("models/yolox_nano.onnx");
  const std::string tool = testing::SharedData("../tools/walkers/make_walkers.py");
  ASSERT_TRUE(fs::exists(tool)) << tool;
  const std::string dir = testing::TestTempDir();
  const std::string folder = dir + "/fr1_walk3";
  const std::string command = "/usr/bin/python3 '" + tool + "' '" + testing::SharedData("tum_fr1_rpy_head250") +
                              "' '" + folder + "' --walkers 3 --seed 11 --count 60 > '" + dir +
                              "/walkers.log' 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  fs::rename(folder + "/masks", dir + "/hidden_masks");  // the detector finds the people
  const auto dataset = OpenDataset(folder);
  PipelineOptions o = PresetOptions(PresetForDataset(*dataset));
  o.masking.segmenter.model_path = testing::SharedData("models/yolox_nano.onnx");
  o.background_prior = "frames";
  o.detector_look_ahead = look_ahead;
  o.max_frames = 60;
  o.iterations_per_keyframe = 15;
  o.mapper.train_downscale = 4;
  o.final_iterations = 0;
  testing::SkipExtraOutputs(&o);
  PipelineHooks quiet;
  quiet.show_progress = false;

  PipelineOptions sequential = o;
  sequential.sequential = true;
  const PipelineResult s = RunPipeline(sequential, *dataset, dir + "/sequential", quiet);
  const PipelineResult fast = RunPipeline(o, *dataset, dir + "/fast", quiet);
  PipelineOptions slow_options = o;
  slow_options.debug_detector_delay_ms = 150;
  const PipelineResult slow = RunPipeline(slow_options, *dataset, dir + "/slow", quiet);
  std::printf("ATE sequential %.2f cm, threaded %.2f cm, threaded with the detector 150 ms slower %.2f cm "
              "(%ld frames waited, %.0f ms); mode: %s\n",
              100 * s.ate_rmse, 100 * fast.ate_rmse, 100 * slow.ate_rmse, slow.detector_waits,
              slow.detector_wait_ms, slow.mode.c_str());
  ASSERT_TRUE(s.has_ate && fast.has_ate && slow.has_ate);
  // The tum preset's detector runs every 5 frames: looking 3 frames ahead
  // its frames get their own masks, the others masks 1..4 frames old; with
  // the lag, masks 1..5 frames old.
  EXPECT_EQ(slow.mask_look_ahead, look_ahead);
  EXPECT_EQ(slow.mask_lag, look_ahead > 0 ? 0 : 1);
  EXPECT_GT(slow.detector_waits, 0);
  // Measured: lag 6.95 cm all three, look-ahead 3.74 cm all three (lag 4.35
  // cm with the background model off). Before the sequential run kept the
  // threaded lags it gave 1.58 cm here (background off); with its masks 0..4
  // frames old instead of 1..5 it gives 14.0 cm on the same frames of
  // another walker composite: on these frames the ATE swings with which
  // walker pixels a mask misses.
  EXPECT_EQ(ReadAll(dir + "/sequential/trajectory.txt"), ReadAll(dir + "/fast/trajectory.txt"));
  EXPECT_EQ(ReadAll(dir + "/fast/trajectory.txt"), ReadAll(dir + "/slow/trajectory.txt"));
  EXPECT_NEAR(slow.ate_rmse, s.ate_rmse, 0.1 * s.ate_rmse);  // the 10 %
  EXPECT_LT(s.ate_rmse, 0.08);
}

INSTANTIATE_TEST_SUITE_P(Schedules, PipelineTiming, ::testing::Values(3, 0),
                         [](const ::testing::TestParamInfo<int>& p) {
                           return p.param > 0 ? std::string("LookAhead") : std::string("FixedLag");
                         });

}  // namespace
}  // namespace dypho
