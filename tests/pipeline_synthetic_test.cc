// The whole system (`dypho run`) end to end on the built-in synthetic
// dynamic sequence: walkers covering a large part of the view.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <opencv2/imgproc.hpp>

#include "common/files.h"
#include "engine/eval/ate.h"
#include "engine/eval/trajectory.h"
#include "engine/export/export.h"
#include "engine/io/image_io.h"
#include "tracker/cv_view.h"
#include "engine/pipeline/pipeline.h"
#include "engine/render/render.h"
#include "engine/synth/synthetic_scene.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;

// 60 frames at 320x240, two walkers covering up to 40% of an image, light
// mapping so the test stays short.
PipelineOptions TestOptions() {
  PipelineOptions o = PresetOptions("synthetic");
  o.synth.frames = 60;
  o.sequential = true;
  o.iterations_per_keyframe = 10;
  o.final_iterations = 30;
  o.write_glb = false;
  o.keyframe_renders = 2;
  o.eval_every = 20;
  o.overlay_every = 20;
  return o;
}

const Dataset& Sequence() {
  static const std::unique_ptr<Dataset> dataset =
      MakeBuiltInSequence(TestOptions(), std::string(DYPHO_BINARY_DIR) + "/test_tmp/pipeline_synthetic_sequence");
  return *dataset;
}

// Fraction of pixels, over a few frames, where the map shows something
// clearly in front of the static room (a ghost of a walker): rendered at the
// ground-truth pose, alpha > 0.5 and depth nearer than the walker-free
// room's exact depth (its nearest within 5 px) by more than 0.2 m.
// DYPHO_GHOST_DEBUG=1 writes the ghost pixels beside the map as PNGs.
double GhostFraction(const std::string& map_path) {
  const PipelineOptions o = TestOptions();
  SynthOptions so = o.synth;
  ParseSynthMotion(o.synth_motion, &so.motion);
  const SyntheticScene scene(so);
  const GaussianCloud cloud = LoadMap(map_path);
  kernels::RasterSettings settings;
  settings.sh_degree = o.mapper.sh_degree;
  long ghosts = 0, pixels = 0;
  for (int f = 0; f < scene.num_frames(); f += 6) {
    const Rigid3d world_from_cam = scene.trajectory().world_from_cam[f];
    const SynthStaticView room = scene.RenderStatic(world_from_cam, scene.camera());
    const RenderedView view = RenderView(cloud, scene.camera(), world_from_cam.Inverse(), settings);
    const ImageF depth = NormalizedDepth(view, 0.5f);
    // The nearest room depth within 5 px: blur across the room's own depth
    // edges is not a ghost.
    cv::Mat near_room;
    cv::erode(CvView(room.depth), near_room, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(11, 11)));
    ImageU8 debug(depth.width(), depth.height(), 1);
    for (size_t i = 0; i < depth.size(); ++i) {
      const float d = depth.data()[i], z = near_room.ptr<float>()[i];
      const bool ghost = d > 0 && z > 0 && d < z - 0.2f;
      ghosts += ghost;
      debug.data()[i] = ghost ? 255 : 0;
      ++pixels;
    }
    if (std::getenv("DYPHO_GHOST_DEBUG")) WriteGray8(map_path + "." + std::to_string(f) + ".ghosts.png", debug);
  }
  return static_cast<double>(ghosts) / pixels;
}

TEST(PipelineSynthetic, FullSystemTracksFarBetterThanNoMaskingAndTheMapHasNoGhosts) {
  const Dataset& dataset = Sequence();
  const std::string dir = testing::TestTempDir();
  const PipelineResult full = RunPipeline(TestOptions(), dataset, dir + "/full");
  PipelineOptions off = TestOptions();
  DisableStage(&off, "masking");
  const PipelineResult none = RunPipeline(off, dataset, dir + "/none");
  std::printf("ATE full %.2f cm, no masking %.2f cm; PSNR full %.2f dB, no masking %.2f dB; mask fraction %.3f\n",
              100 * full.ate_rmse, 100 * none.ate_rmse, full.psnr, none.psnr, full.mean_mask_fraction);
  ASSERT_TRUE(full.has_ate && none.has_ate);
  EXPECT_EQ(full.tracked, full.frames);
  EXPECT_LT(full.ate_rmse, 0.03);
  EXPECT_GT(none.ate_rmse, 4.0 * full.ate_rmse);
  EXPECT_GT(full.psnr, none.psnr);
  EXPECT_GT(full.num_gaussians, 1000);
  for (const char* name : {"trajectory.txt", "keyframes.txt", "map.ply", "map.splat", "report.md", "metrics.json",
                           "timings.png", "trajectory_top.png", "renders.png", "options.yaml"})
    EXPECT_TRUE(fs::exists(dir + "/full/" + name)) << name;
  EXPECT_EQ(ReadTumTrajectory(dir + "/full/trajectory.txt").size(), 60u);

  // Ghosts: mapped with ground-truth poses, so only the masks differ.
  PipelineOptions gt = TestOptions();
  gt.poses = "gt";
  RunPipeline(gt, dataset, dir + "/gt_full");
  // The reference: the generator's exact masks on every frame, nothing else.
  PipelineOptions exact = gt;
  exact.masking.schedule.interval = 1;
  DisableStage(&exact, "flow");
  DisableStage(&exact, "refine");
  DisableStage(&exact, "epipolar");
  RunPipeline(exact, dataset, dir + "/gt_exact");
  DisableStage(&gt, "masking");
  RunPipeline(gt, dataset, dir + "/gt_carved");  // no masks: only free-space carving keeps walkers out
  gt.carve_votes = 0;
  RunPipeline(gt, dataset, dir + "/gt_none");
  const double ghosts_full = GhostFraction(dir + "/gt_full/map.ply");
  const double ghosts_exact = GhostFraction(dir + "/gt_exact/map.ply");
  const double ghosts_carved = GhostFraction(dir + "/gt_carved/map.ply");
  const double ghosts_none = GhostFraction(dir + "/gt_none/map.ply");
  // Pixels nearer than the room also come from Gaussians placed where depth is missing (at the frame's median
  // depth) and from blur at depth edges; the exact-mask map measures that floor.
  std::printf("pixels in front of the room: full %.4f, exact masks %.4f, no masking but carving %.4f, neither %.4f\n",
              ghosts_full, ghosts_exact, ghosts_carved, ghosts_none);
  // Measured: full 1.25%, exact masks 0.25%, no masking 49% (small remnants: a foot, an arm's edge).
  EXPECT_LT(ghosts_full, ghosts_exact + 0.02);
  EXPECT_LT(ghosts_full, 0.1 * ghosts_none);
  EXPECT_GT(ghosts_none, ghosts_exact + 0.1);  // the measure sees walkers when they are mapped
  EXPECT_LT(ghosts_carved, 0.5 * ghosts_none);   // carving alone removes most of them
}

std::string Bytes(const std::string& path) { return ReadTextFile(path); }

// seen_through in the whole system, threaded and with the progress lines
// on (the drain that waits for the queue must see the held keyframes
// released): every keyframe is mapped, and without any mask or carving the
// walkers mostly stay out of the map.
TEST(PipelineSynthetic, SeenThroughMapsEveryKeyframeAndKeepsWalkersOut) {
  const Dataset& dataset = Sequence();
  const std::string dir = testing::TestTempDir();
  PipelineOptions o = TestOptions();
  o.poses = "gt";
  DisableStage(&o, "masking");
  o.carve_votes = 0;
  RunPipeline(o, dataset, dir + "/none");
  o.sequential = false;
  o.seen_through.enabled = true;
  PipelineHooks hooks;
  hooks.show_progress = true;
  const PipelineResult r = RunPipeline(o, dataset, dir + "/seen", hooks);
  EXPECT_GT(r.keyframes, 3);
  EXPECT_EQ(r.mapped_keyframes, r.keyframes);
  const double none = GhostFraction(dir + "/none/map.ply"), seen = GhostFraction(dir + "/seen/map.ply");
  std::printf("pixels in front of the room without masks: %.4f, with seen_through: %.4f\n", none, seen);
  EXPECT_LT(seen, 0.5 * none);
}

TEST(PipelineSynthetic, SequentialModeIsIdenticalRunToRun) {
  const Dataset& dataset = Sequence();
  const std::string dir = testing::TestTempDir();
  PipelineOptions o = TestOptions();
  o.max_frames = 25;
  RunPipeline(o, dataset, dir + "/a");
  RunPipeline(o, dataset, dir + "/b");
  EXPECT_EQ(Bytes(dir + "/a/trajectory.txt"), Bytes(dir + "/b/trajectory.txt"));
  EXPECT_EQ(Bytes(dir + "/a/map.ply"), Bytes(dir + "/b/map.ply"));
}

TEST(PipelineSynthetic, StopRequestLeavesValidOutputsOfTheFramesProcessed) {
  const Dataset& dataset = Sequence();
  const std::string dir = testing::TestTempDir();
  PipelineOptions o = TestOptions();
  o.sequential = false;  // threads, as in `dypho run`
  std::atomic<bool> stop{false};
  PipelineHooks hooks;
  hooks.stop = &stop;
  hooks.on_frame = [&](long done, long) {
    if (done == 18) stop = true;
  };
  const PipelineResult r = RunPipeline(o, dataset, dir, hooks);
  EXPECT_TRUE(r.interrupted);
  EXPECT_EQ(r.frames, 18);
  EXPECT_EQ(ReadTumTrajectory(dir + "/trajectory.txt").size(), 18u);
  const GaussianCloud map = LoadMap(dir + "/map.ply");
  EXPECT_GT(map.size(), 0);
  EXPECT_NE(ReadTextFile(dir + "/report.md").find("interrupted"), std::string::npos);
  for (const auto& entry : fs::directory_iterator(dir))  // no temporary files left behind
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
}

TEST(PipelineSynthetic, GroundTruthPosesNeedGroundTruth) {
  const std::string dir = testing::TestTempDir();
  fs::copy(Sequence().folder(), dir + "/seq", fs::copy_options::recursive);
  fs::remove(dir + "/seq/groundtruth.txt");
  const std::unique_ptr<Dataset> dataset = OpenDataset(dir + "/seq");
  PipelineOptions o = TestOptions();
  o.poses = "gt";
  EXPECT_INVALID_INPUT(RunPipeline(o, *dataset, dir + "/out"), "groundtruth.txt");
}

}  // namespace
}  // namespace dypho
