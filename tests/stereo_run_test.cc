// `dypho run` on the first KITTI pairs (kitti_stereo_51, preset "stereo"):
// with sparse stereo tracking the frame loader computes only half-resolution
// preview disparities and the engine the dense disparity of exactly the
// keyframes (engine/pipeline/stereo_frames.h); with
// stereo_preview_downscale 1 every frame gets the dense one in the loader
// and the engine computes none. metrics.json records the counts. The
// preset's dense map keeps the road and the cars (1-25 m).
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "engine/dataset/dataset.h"
#include "engine/pipeline/pipeline.h"
#include "tests/pipeline_test_options.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

constexpr int kFrames = 12;

PipelineOptions RunOptions(int preview_downscale) {
  PipelineOptions o = PresetOptions("stereo");
  o.sequential = true;
  o.max_frames = kFrames;
  o.iterations_per_keyframe = 3;
  o.final_iterations = 0;
  o.mapper.train_downscale = 4;
  o.stereo_preview_downscale = preview_downscale;
  testing::SkipExtraOutputs(&o);
  return o;
}

nlohmann::json Metrics(const std::string& dir) {
  std::ifstream in(dir + "/metrics.json");
  return nlohmann::json::parse(in);
}

TEST(StereoRun, KittiDenseDisparityForExactlyTheKeyframes) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const auto dataset = OpenDataset(testing::SharedData("kitti_stereo_51"));
  const std::string out = std::string(DYPHO_BINARY_DIR) + "/test_tmp/stereo_run/preview";
  const PipelineResult r = RunPipeline(RunOptions(2), *dataset, out);
  EXPECT_EQ(r.tracked, kFrames);
  EXPECT_GE(r.keyframes, 2);
  EXPECT_LT(r.keyframes, kFrames);
  // One preview per frame, plus the look-ahead frame of the segment start
  // when the flow mask is on (the first frame's flow; off in the stereo preset).
  const int look_ahead = RunOptions(2).masking.use_flow ? 1 : 0;
  EXPECT_EQ(r.frame_disparities, kFrames + look_ahead);
  EXPECT_EQ(r.frame_disparity_downscale, 2);
  EXPECT_EQ(r.keyframe_disparities, r.keyframes);
  EXPECT_GT(r.keyframe_disparity_ms, 0.0);
  EXPECT_GT(r.timings.disparity_ms, 0.0);
  EXPECT_GT(r.num_gaussians, 1000);
  // The preset's dense map range (1-25 m, 10 cm voxels): the road and the cars, not only what is nearer than 4 m.
  EXPECT_EQ(r.dense_keyframes, r.keyframes);
  EXPECT_GT(r.dense_voxels, 20000);
  const nlohmann::json m = Metrics(out);
  EXPECT_EQ(m["keyframe_disparities"].get<int>(), r.keyframes);
  EXPECT_EQ(m["frame_disparities"].get<int>(), kFrames + look_ahead);
  EXPECT_EQ(m["frame_disparity_downscale"].get<int>(), 2);
  EXPECT_GT(m["timings_ms"]["disparity"].get<double>(), 0.0);
}

TEST(StereoRun, KittiEagerDisparityWithPreviewsOff) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const auto dataset = OpenDataset(testing::SharedData("kitti_stereo_51"));
  const std::string out = std::string(DYPHO_BINARY_DIR) + "/test_tmp/stereo_run/eager";
  const PipelineResult r = RunPipeline(RunOptions(1), *dataset, out);
  EXPECT_EQ(r.tracked, kFrames);
  EXPECT_GE(r.keyframes, 2);
  EXPECT_EQ(r.frame_disparities, kFrames + (RunOptions(1).masking.use_flow ? 1 : 0));
  EXPECT_EQ(r.frame_disparity_downscale, 1);
  EXPECT_EQ(r.keyframe_disparities, 0);
  EXPECT_GT(r.num_gaussians, 1000);
}

}  // namespace
}  // namespace dypho
