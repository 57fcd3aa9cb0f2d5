// `dypho run` with keyframe poses refined against the map
// (mapper.refine_poses) on real TUM fr1/rpy frames: trajectory_map.txt
// follows the refined keyframes (engine/map/trajectory_follow.h), its
// keyframe lines are the keyframes' poses in keyframes.txt, trajectory.txt
// keeps the tracker's poses, and the map scores higher at the followed
// poses than at the tracker's.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "engine/eval/map_score.h"
#include "engine/eval/trajectory.h"
#include "engine/export/export.h"
#include "engine/pipeline/pipeline.h"
#include "tests/pipeline_test_options.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

// Sequential, without the background model (it renders the map, so the
// masks, hence the tracker, would depend on the map): both runs below track
// the same trajectory.
PipelineOptions Options(bool refine_poses) {
  PipelineOptions o = PresetOptions("tum");
  o.sequential = true;
  o.max_frames = 90;
  o.masking.use_background = false;
  o.iterations_per_keyframe = 20;
  o.mapper.train_downscale = 4;
  o.final_iterations = 300;
  o.mapper.refine_poses = refine_poses;
  testing::SkipExtraOutputs(&o);
  return o;
}

TEST(PipelineRefinePoses, TheTrajectoryFollowsTheRefinedKeyframesAndTheMapScoresHigherThere) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  const std::unique_ptr<Dataset> dataset = OpenDataset(testing::SharedData("tum_fr1_rpy_head250"));
  PipelineHooks quiet;
  quiet.show_progress = false;
  const std::string dir = testing::TestTempDir();
  const PipelineResult refined = RunPipeline(Options(true), *dataset, dir + "/refined", quiet);
  const PipelineResult plain = RunPipeline(Options(false), *dataset, dir + "/plain", quiet);
  EXPECT_EQ(plain.keyframe_follow.keyframes, 0);

  // The keyframes moved, and their trajectory lines are where they moved to.
  const Trajectory keyframes = ReadTumTrajectory(dir + "/refined/keyframes.txt");
  const Trajectory followed = ReadTumTrajectory(dir + "/refined/trajectory_map.txt");
  const Trajectory tracked = ReadTumTrajectory(dir + "/plain/trajectory.txt");
  EXPECT_FALSE(std::filesystem::exists(dir + "/plain/trajectory_map.txt"));
  // The tracker's poses do not depend on the map.
  EXPECT_EQ(FormatTumTrajectory(ReadTumTrajectory(dir + "/refined/trajectory.txt")), FormatTumTrajectory(tracked));
  ASSERT_GE(keyframes.size(), 3u);
  ASSERT_EQ(followed.size(), tracked.size());
  EXPECT_EQ(refined.keyframe_follow.keyframes, static_cast<int>(keyframes.size()));
  EXPECT_GT(refined.keyframe_follow.max_translation, 1e-4);
  int matched = 0;
  for (size_t k = 0; k < keyframes.size(); ++k) {
    for (size_t i = 0; i < followed.size(); ++i) {
      if (std::abs(followed.timestamps[i] - keyframes.timestamps[k]) > 1e-5) continue;
      ++matched;
      EXPECT_LT((followed.world_from_cam[i].translation - keyframes.world_from_cam[k].translation).norm(), 1e-5);
      EXPECT_LT(RotationAngle(followed.world_from_cam[i].rotation, keyframes.world_from_cam[k].rotation), 1e-5);
    }
  }
  EXPECT_EQ(matched, static_cast<int>(keyframes.size()));

  // The refined map at the followed poses against the tracker's poses,
  // frames that are not keyframes.
  const GaussianCloud map = LoadMap(dir + "/refined/map.ply");
  MapScoreOptions so;
  so.every = 3;
  so.max_frames = 90;
  so.eval_downscale = 2;
  so.trained_timestamps = keyframes.timestamps;
  const MapScore at_followed = ScoreMap(map, *dataset, followed, so);
  const MapScore at_tracked = ScoreMap(map, *dataset, tracked, so);
  std::printf("%d keyframes moved by %.1f mm, %.2f deg on average; novel views: %.2f dB at the followed poses, "
              "%.2f dB at the tracker's\n",
              refined.keyframe_follow.keyframes, 1000 * refined.keyframe_follow.mean_translation,
              refined.keyframe_follow.mean_rotation_deg, at_followed.untrained.psnr, at_tracked.untrained.psnr);
  ASSERT_GE(at_followed.untrained.frames, 20);
  EXPECT_GT(at_followed.untrained.psnr, at_tracked.untrained.psnr + 0.1);
}

}  // namespace
}  // namespace dypho
