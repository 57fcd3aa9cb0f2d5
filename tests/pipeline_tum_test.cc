// The whole system (`dypho run`) on the real TUM RGB-D fr1/rpy frames (static
// scene, fast rotation, Kinect v1 rolling shutter) with the ORB tracker and
// the YOLOX detector: every frame tracked, ATE and PSNR above floors.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "engine/eval/trajectory.h"
#include "engine/pipeline/pipeline.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

// The TUM preset with light mapping (160x120 training, few keyframes and
// steps) to keep the tests short; sequential, so the floors do not depend on
// the machine's load.
PipelineOptions LightTumOptions(const Dataset& dataset) {
  PipelineOptions o = PresetOptions(PresetForDataset(dataset));
  EXPECT_EQ(o.preset, "tum");
  o.masking.segmenter.model_path = testing::SharedData("models/yolox_nano.onnx");
  o.sequential = true;
  o.iterations_per_keyframe = 5;
  o.mapper.train_downscale = 4;
  o.final_iterations = 60;
  o.keyframes.max_rotation_deg = 15.0;
  o.keyframes.max_frame_gap = 30;
  o.write_glb = false;
  o.keyframe_renders = 2;
  o.eval_every = 25;
  o.eval_downscale = 2;
  return o;
}

void Print(const char* what, const PipelineResult& r) {
  std::printf("fr1/rpy, %s: %ld/%ld frames tracked, ATE %.2f cm, PSNR %.2f dB, SSIM %.3f, %d keyframes, %d Gaussians, "
              "%.1f tracking fps\n",
              what, r.tracked, r.frames, 100 * r.ate_rmse, r.psnr, r.ssim, r.keyframes, r.num_gaussians,
              r.tracking_fps);
}

TEST(PipelineTum, Fr1RpyEveryFrameTrackedWithAccurateTrajectoryAndMap) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  DYPHO_REQUIRE_SHARED_DATA("models/yolox_nano.onnx");
  const std::unique_ptr<Dataset> dataset = OpenDataset(testing::SharedData("tum_fr1_rpy_head250"));
  const PipelineOptions o = LightTumOptions(*dataset);
  ASSERT_FALSE(o.map_sensor_model);  // the plain map scores higher on novel views
  const std::string dir = testing::TestTempDir();
  const PipelineResult r = RunPipeline(o, *dataset, dir);
  Print("TUM preset", r);
  EXPECT_EQ(r.frames, 250);
  EXPECT_EQ(r.tracked, 250);
  ASSERT_TRUE(r.has_ate);
  EXPECT_LT(r.ate_rmse, 0.03);  // the tracker alone reaches about 1.3 cm (tracker_tum_test)
  EXPECT_GT(r.psnr, 17.0);
  EXPECT_GT(r.ssim, 0.6);
  EXPECT_LT(r.mean_mask_fraction, 0.1);  // a static scene: little is masked
  EXPECT_EQ(ReadTumTrajectory(dir + "/trajectory.txt").size(), 250u);

  // (The map's sensor model is covered by map_tum_test on the fast-rotation
  // frames; in the preset it is off because the plain map scores higher on
  // novel views.)
}

}  // namespace
}  // namespace dypho
