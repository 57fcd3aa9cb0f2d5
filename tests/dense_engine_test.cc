// The dense map through the embedding API (engine/api.h) on the synthetic
// dynamic room: dense.ply holds the static scene only when the walkers are
// masked (and holds them when not), host pose corrections move the points,
// and bad calls are clear errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "engine/api.h"
#include "engine/export/knn.h"
#include "engine/synth/synthetic_scene.h"
#include "tests/dense_ply.h"
#include "tests/engine_test_options.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

using testing::ReadDensePly;

SynthOptions Scene() {
  SynthOptions o;
  o.width = 160;
  o.height = 120;
  o.frames = 24;
  o.num_walkers = 2;
  o.depth_noise = false;
  o.seed = 7;
  return o;
}

EngineOptions Options(const Camera& camera) {
  EngineOptions o = testing::SmallEngineOptions(camera, true);
  o.mapper.train_downscale = 2;
  o.iterations_per_keyframe = 1;
  o.final_iterations = 0;
  o.carve_votes = 0;
  return o;
}

struct MappedRun {
  std::unique_ptr<Engine> engine;
  std::vector<Rigid3d> keyframe_poses;  // cam_from_world
};

MappedRun MapScene(const SyntheticScene& scene, bool masks, bool synchronous = true) {
  MappedRun run;
  EngineOptions o = Options(scene.camera());
  o.synchronous = synchronous;
  run.engine = Engine::Create(o);
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SynthFrame f = scene.Render(i);
    FrameBuffers b;
    b.timestamp = f.timestamp;
    b.rgb = f.rgb.data();
    b.depth_m = f.depth_noisy.data();
    if (masks) b.dynamic_mask = f.mask.data();
    const Rigid3d pose = f.world_from_cam.Inverse();
    if (run.engine->PushFrame(b, &pose).keyframe) run.keyframe_poses.push_back(pose);
  }
  run.engine->Finish();
  return run;
}

// Points farther than 4 cm from the static scene's surfaces (walkers): the
// static scene alone rendered at 4x resolution from every keyframe pose,
// unprojected, is the reference surface.
int PointsOffTheStaticScene(const SyntheticScene& scene, const ColoredPoints& cloud,
                            const std::vector<Rigid3d>& poses) {
  Camera cam = scene.camera();
  cam.fx *= 4;
  cam.fy *= 4;
  cam.cx = (cam.cx + 0.5) * 4 - 0.5;
  cam.cy = (cam.cy + 0.5) * 4 - 0.5;
  cam.width *= 4;
  cam.height *= 4;
  std::vector<float> surface;
  for (const Rigid3d& cam_from_world : poses) {
    const Rigid3d world_from_cam = cam_from_world.Inverse();
    const SynthStaticView view = scene.RenderStatic(world_from_cam, cam);
    for (int y = 0; y < cam.height; ++y) {
      for (int x = 0; x < cam.width; ++x) {
        const float d = view.depth.at(x, y);
        if (!(d > 0)) continue;
        const Eigen::Vector3d p = world_from_cam * Eigen::Vector3d((x - cam.cx) / cam.fx * d, (y - cam.cy) / cam.fy * d, d);
        for (int a = 0; a < 3; ++a) surface.push_back(static_cast<float>(p[a]));
      }
    }
  }
  const std::vector<double> d =
      NearestDistances(surface.data(), static_cast<int>(surface.size() / 3), cloud.xyz.data(), cloud.size());
  return static_cast<int>(std::count_if(d.begin(), d.end(), [](double v) { return v > 0.04; }));
}

TEST(DenseEngine, DenseCloudHoldsTheStaticSceneOnlyWhenDynamicPixelsAreMasked) {
  const SyntheticScene scene(Scene());
  const std::string dir = testing::TestTempDir();
  const MappedRun masked = MapScene(scene, true);
  masked.engine->Save(dir + "/masked");  // map.ply, keyframes.txt, dense.ply
  const ColoredPoints clean = ReadDensePly(dir + "/masked/dense.ply");
  const MappedRun unmasked = MapScene(scene, false);
  unmasked.engine->SaveDenseCloud(dir + "/unmasked.ply");
  const ColoredPoints dirty = ReadDensePly(dir + "/unmasked.ply");
  const int off_clean = PointsOffTheStaticScene(scene, clean, masked.keyframe_poses);
  const int off_dirty = PointsOffTheStaticScene(scene, dirty, unmasked.keyframe_poses);
  const DenseMapStats stats = masked.engine->DenseStatus();
  std::printf("dense synthetic room: %d keyframes, %d points masked (%d off the static scene), %d unmasked (%d off); "
              "%.2f ms per keyframe\n",
              stats.keyframes_added, clean.size(), off_clean, dirty.size(), off_dirty, stats.mean_ms());
  EXPECT_EQ(stats.keyframes_added, static_cast<int>(masked.keyframe_poses.size()));
  EXPECT_GT(clean.size(), 2000);
  EXPECT_EQ(off_clean, 0);
  EXPECT_GT(off_dirty, 100);
}

TEST(DenseEngine, HostPoseCorrectionsMoveTheDensePoints) {
  const SyntheticScene scene(Scene());
  const std::string dir = testing::TestTempDir();
  const MappedRun run = MapScene(scene, true);
  run.engine->SaveDenseCloud(dir + "/before.ply");
  const ColoredPoints before = ReadDensePly(dir + "/before.ply");
  // Every keyframe 1 m along world x: the whole cloud follows (50 cells of
  // 2 cm: the same cells, shifted).
  const Rigid3d shift(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1.0, 0, 0));
  for (size_t k = 0; k < run.keyframe_poses.size(); ++k) {
    run.engine->UpdateKeyframePose(static_cast<int>(k), run.keyframe_poses[k] * shift.Inverse());
  }
  run.engine->SaveDenseCloud(dir + "/after.ply");
  const ColoredPoints after = ReadDensePly(dir + "/after.ply");
  ASSERT_GT(before.size(), 1000);
  EXPECT_NEAR(after.size(), before.size(), 0.01 * before.size());
  Eigen::Vector3d mean_before(0, 0, 0), mean_after(0, 0, 0);
  for (int i = 0; i < before.size(); ++i) mean_before += Eigen::Vector3d(before.xyz[3 * i], before.xyz[3 * i + 1], before.xyz[3 * i + 2]);
  for (int i = 0; i < after.size(); ++i) mean_after += Eigen::Vector3d(after.xyz[3 * i], after.xyz[3 * i + 1], after.xyz[3 * i + 2]);
  mean_before /= before.size();
  mean_after /= after.size();
  EXPECT_NEAR(mean_after.x() - mean_before.x(), 1.0, 0.01);
  EXPECT_NEAR(mean_after.y() - mean_before.y(), 0.0, 0.01);
  EXPECT_NEAR(mean_after.z() - mean_before.z(), 0.0, 0.01);
  EXPECT_GE(run.engine->DenseStatus().pose_updates, static_cast<int>(run.keyframe_poses.size()));

  try {
    run.engine->UpdateKeyframePose(999, Rigid3d());
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("no keyframe 999"), std::string::npos) << e.what();
  }
  EngineOptions off = Options(scene.camera());
  off.dense.enabled = false;
  auto engine = Engine::Create(off);
  EXPECT_THROW(engine->SaveDenseCloud(dir + "/none.ply"), InvalidInput);
  EXPECT_FALSE(std::ifstream(dir + "/none.ply").good());
}

// The dense map depends on the keyframes and their poses only, not on
// timing: the threaded engine (mapping and dense threads) writes the same
// dense.ply bytes as the synchronous one (--sequential).
TEST(DenseEngine, ThreadedAndSequentialRunsWriteTheSameDenseCloud) {
  const SyntheticScene scene(Scene());
  const std::string dir = testing::TestTempDir();
  const MappedRun sequential = MapScene(scene, true, true);
  const MappedRun threaded = MapScene(scene, true, false);
  sequential.engine->SaveDenseCloud(dir + "/sequential.ply");
  threaded.engine->SaveDenseCloud(dir + "/threaded.ply");
  auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string a = bytes(dir + "/sequential.ply");
  EXPECT_GT(a.size(), 10000u);
  EXPECT_TRUE(a == bytes(dir + "/threaded.ply"));
}

// With pose refinement the mapper moves keyframes; the saved dense cloud is
// at the refined poses (the same cloud as a dense map built directly at them).
TEST(DenseEngine, RefinedKeyframePosesCarryTheirPoints) {
  const SyntheticScene scene(Scene());
  EngineOptions o = Options(scene.camera());
  o.mapper.refine_poses = true;
  o.mapper.lr_pose_translation = 2e-3f;  // large steps: the poses move visibly
  o.iterations_per_keyframe = 10;
  auto engine = Engine::Create(o);
  std::vector<KeyframeInput> keyframes;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SynthFrame f = scene.Render(i);
    FrameBuffers b;
    b.timestamp = f.timestamp;
    b.rgb = f.rgb.data();
    b.depth_m = f.depth_noisy.data();
    b.dynamic_mask = f.mask.data();
    const Rigid3d pose = f.world_from_cam.Inverse();
    if (engine->PushFrame(b, &pose).keyframe) {
      KeyframeInput k;
      k.rgb = f.rgb;
      k.depth = f.depth_noisy;
      k.dynamic_mask = f.mask;
      keyframes.push_back(std::move(k));
    }
  }
  engine->Finish();
  const std::string dir = testing::TestTempDir();
  engine->SaveDenseCloud(dir + "/refined.ply");
  const ColoredPoints saved = ReadDensePly(dir + "/refined.ply");
  DenseMapper direct(scene.camera(), o.dense, true);
  for (size_t k = 0; k < keyframes.size(); ++k) {
    keyframes[k].cam_from_world = engine->KeyframePose(static_cast<int>(k));
    direct.Add(static_cast<int>(k), keyframes[k]);
  }
  EXPECT_GT(engine->DenseStatus().pose_updates, 0);
  const ColoredPoints expected = direct.Cloud();
  ASSERT_EQ(saved.size(), expected.size());
  EXPECT_EQ(saved.xyz, expected.xyz);
  EXPECT_EQ(saved.rgb, expected.rgb);
}

}  // namespace
}  // namespace dypho
