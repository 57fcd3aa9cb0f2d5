// EngineOptions::seen_through through the embedding API (engine/api.h):
// keyframes wait for the frames after them, a host's pose correction reaches
// a waiting keyframe, Finish maps every one, and walkers that no mask names
// leave the map because the frames around each keyframe see through them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "engine/api.h"
#include "engine/eval/image_metrics.h"
#include "engine/io/image_io.h"
#include "engine/synth/synthetic_scene.h"
#include "tests/engine_test_options.h"

namespace dypho {
namespace {

SynthOptions Walkers() {
  SynthOptions o;
  o.width = 160;
  o.height = 120;
  o.frames = 48;
  o.num_walkers = 2;
  o.depth_noise = false;
  o.seed = 3;
  return o;
}

EngineOptions Options(const Camera& camera, bool seen_through) {
  EngineOptions o = testing::SmallEngineOptions(camera, true);
  o.seen_through.enabled = seen_through;
  o.seen_through.window = 8;
  o.seen_through.neighbours = 8;
  o.seen_through.votes = 2;
  o.seen_through.downscale = 2;
  return o;
}

struct MapRun {
  int keyframes = 0;
  int most_held = 0;
  bool held_while_pushing = true;  // every keyframe waited (synchronous mapping would map it at once)
  EngineStatus status;
  double psnr = 0.0;  // mean over frames against the static scene
};

MapRun MapWalkers(const SyntheticScene& scene, bool seen_through, bool correct_a_held_keyframe) {
  auto engine = Engine::Create(Options(scene.camera(), seen_through));
  MapRun run;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SynthFrame f = scene.Render(i);
    FrameBuffers b;
    b.timestamp = f.timestamp;
    b.rgb = f.rgb.data();
    b.depth_m = f.depth_noisy.data();  // no mask: the walkers are not named
    const Rigid3d pose = f.world_from_cam.Inverse();
    const PushResult r = engine->PushFrame(b, &pose);
    if (!r.keyframe) continue;
    ++run.keyframes;
    const EngineStatus s = engine->Status();
    run.most_held = std::max(run.most_held, s.held_keyframes);
    if (seen_through) run.held_while_pushing = run.held_while_pushing && s.mapped_keyframes < s.keyframes;
    if (correct_a_held_keyframe && run.keyframes == 2) {
      // A correction of a waiting keyframe is its pose when it is mapped.
      Rigid3d moved = pose;
      moved.translation.x() += 0.01;
      engine->UpdateKeyframePose(r.keyframe_id, moved);
      EXPECT_NEAR((engine->KeyframePose(r.keyframe_id).translation - moved.translation).norm(), 0.0, 1e-12);
      engine->UpdateKeyframePose(r.keyframe_id, pose);
      EXPECT_NEAR((engine->KeyframePose(r.keyframe_id).translation - pose.translation).norm(), 0.0, 1e-12);
    }
  }
  engine->Finish();
  run.status = engine->Status();
  int n = 0;
  for (int i = 2; i < scene.num_frames(); i += 6, ++n) {
    const Rigid3d world_from_cam = scene.Render(i).world_from_cam;
    const SynthStaticView clean = scene.RenderStatic(world_from_cam, scene.camera());
    const EngineRender r = engine->Render(scene.camera(), world_from_cam.Inverse());
    ImageF color(r.width, r.height, 3);
    for (size_t k = 0; k < color.size(); ++k) color.data()[k] = std::min(1.0f, std::max(0.0f, r.color[k]));
    run.psnr += Psnr(color, ToFloat(clean.rgb));
  }
  run.psnr /= n;
  return run;
}

TEST(EngineSeenThrough, KeyframesWaitAndUnnamedWalkersLeaveTheMap) {
  const SyntheticScene scene(Walkers());
  const MapRun off = MapWalkers(scene, false, false);
  const MapRun on = MapWalkers(scene, true, true);
  std::printf("walkers, no masks: %.2f dB against the static scene; seen-through on: %.2f dB (%lld pixels masked)\n",
              off.psnr, on.psnr, on.status.seen_through_pixels);
  ASSERT_GE(on.keyframes, 6);
  EXPECT_EQ(on.keyframes, off.keyframes);  // the selector is the same
  EXPECT_TRUE(on.held_while_pushing);
  EXPECT_GE(on.most_held, 2);              // 8 frames wait, a keyframe at least every 4th frame
  EXPECT_EQ(off.most_held, 0);
  EXPECT_EQ(on.status.held_keyframes, 0);  // Finish released them all ...
  EXPECT_EQ(on.status.mapped_keyframes, on.keyframes);  // ... and mapped them
  EXPECT_EQ(on.status.queued_keyframes, 0);
  EXPECT_GT(on.status.seen_through_pixels, 0);
  EXPECT_EQ(off.status.seen_through_pixels, 0);
  EXPECT_GT(on.psnr, off.psnr + 1.0);
}

TEST(EngineSeenThrough, BadOptionIsAClearError) {
  const SyntheticScene scene(Walkers());
  EngineOptions o = Options(scene.camera(), true);
  o.seen_through.votes = 0;
  try {
    Engine::Create(o);
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("seen_through.votes"), std::string::npos) << e.what();
  }
  o.seen_through.enabled = false;  // off: not checked
  EXPECT_NO_THROW(Engine::Create(o));
}

}  // namespace
}  // namespace dypho
