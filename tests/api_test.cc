// The embedding API (engine/api.h): frames in as plain buffers, keyframe
// selection, synchronous and threaded mapping, pose corrections from a host,
// rendering, saving, bounded queues, concurrent use, and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "engine/api.h"
#include "engine/eval/image_metrics.h"
#include "engine/eval/trajectory.h"
#include "engine/export/ply.h"
#include "engine/dataset/dataset.h"
#include "engine/io/image_io.h"
#include "engine/map/sensor_model.h"
#include "engine/synth/synthetic_scene.h"
#include "tests/engine_test_options.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

SynthOptions Scene(int frames) {
  SynthOptions o;
  o.width = 160;
  o.height = 120;
  o.frames = frames;
  o.num_walkers = 0;
  o.depth_noise = false;
  o.seed = 5;
  return o;
}

EngineOptions Options(const Camera& camera, bool synchronous) {
  return ::dypho::testing::SmallEngineOptions(camera, synchronous);
}

PushResult Push(Engine& engine, const SynthFrame& f, bool with_pose = true) {
  FrameBuffers b;
  b.timestamp = f.timestamp;
  b.rgb = f.rgb.data();
  b.depth_m = f.depth_noisy.data();
  b.dynamic_mask = f.mask.data();
  const Rigid3d pose = f.world_from_cam.Inverse();
  return engine.PushFrame(b, with_pose ? &pose : nullptr);
}

double RenderPsnr(const Engine& engine, const SyntheticScene& scene, int frame) {
  const SynthFrame f = scene.Render(frame);
  const EngineRender r = engine.Render(scene.camera(), f.world_from_cam.Inverse());
  ImageF color(r.width, r.height, 3);
  for (size_t i = 0; i < color.size(); ++i) color.data()[i] = std::min(1.0f, std::max(0.0f, r.color[i]));
  return Psnr(color, ToFloat(f.rgb));
}

TEST(EngineApi, SynchronousMappingRendersSavesAndReloads) {
  const SyntheticScene scene(Scene(24));
  auto engine = Engine::Create(Options(scene.camera(), true));
  int keyframes = 0;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const PushResult r = Push(*engine, scene.Render(i));
    EXPECT_TRUE(r.has_pose);
    if (r.keyframe) EXPECT_EQ(r.keyframe_id, keyframes++);
  }
  EXPECT_GE(keyframes, 6);  // at least every 4th frame
  engine->Finish();
  const EngineStatus s = engine->Status();
  EXPECT_EQ(s.frames, 24);
  EXPECT_EQ(s.keyframes, keyframes);
  EXPECT_EQ(s.mapped_keyframes, keyframes);
  EXPECT_EQ(s.late_keyframes, 0);
  EXPECT_GT(s.num_gaussians, 1000);
  EXPECT_EQ(s.iterations, keyframes * 20 + 60);
  const double psnr = RenderPsnr(*engine, scene, 13);  // between keyframes
  std::printf("API render PSNR at a held-out frame: %.2f dB\n", psnr);
  EXPECT_GT(psnr, 22.0);

  const std::string dir = ::dypho::testing::TestTempDir() + "/api_save";
  engine->Save(dir);
  const GaussianCloud saved = LoadPly(dir + "/map.ply");
  const GaussianCloud map = engine->Map();
  EXPECT_EQ(saved.means, map.means);
  EXPECT_EQ(saved.sh, map.sh);
  const Trajectory kf = ReadTumTrajectory(dir + "/keyframes.txt");
  ASSERT_EQ(static_cast<int>(kf.timestamps.size()), keyframes);
  EXPECT_LT((kf.world_from_cam[1].translation - engine->KeyframePose(1).Inverse().translation).norm(), 1e-6);
}

// The final refinement stops at its time budget and reports its progress.
TEST(EngineApi, FinalRefinementKeepsToItsTimeBudget) {
  const SyntheticScene scene(Scene(9));
  EngineOptions o = Options(scene.camera(), true);
  o.iterations_per_keyframe = 0;
  o.final_iterations = 1000000;
  o.final_seconds = 0.5;
  auto engine = Engine::Create(o);
  for (int i = 0; i < scene.num_frames(); ++i) Push(*engine, scene.Render(i));
  int calls = 0, last = 0;
  bool monotonic = true;
  const auto start = std::chrono::steady_clock::now();
  const int steps = engine->Finish([&](int done, int planned) {
    ++calls;
    monotonic = monotonic && done > last && planned == 1000000;
    last = done;
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("final refinement: %d steps in %.2f s (budget 0.5 s)\n", steps, seconds);
  EXPECT_GT(steps, 0);
  EXPECT_LT(steps, 1000000);  // a million steps would take hours: the budget stopped it
  EXPECT_EQ(engine->Status().iterations, steps);
  EXPECT_EQ(last, steps);
  EXPECT_GT(calls, 0);
  EXPECT_TRUE(monotonic);
  // A deadline already past: no steps.
  EXPECT_EQ(engine->Finish({}, std::chrono::steady_clock::now()), 0);
  EXPECT_EQ(engine->Status().iterations, steps);
  o.final_seconds = -1.0;
  EXPECT_THROW(Engine::Create(o), InvalidInput);
}

TEST(EngineApi, HostPoseCorrectionMovesTheKeyframesGaussians) {
  const SyntheticScene scene(Scene(9));
  EngineOptions o = Options(scene.camera(), true);
  o.iterations_per_keyframe = 0;
  auto engine = Engine::Create(o);
  for (int i = 0; i < scene.num_frames(); ++i) Push(*engine, scene.Render(i));
  ASSERT_GE(engine->Status().mapped_keyframes, 2);
  const GaussianCloud before = engine->Map();
  const Rigid3d old_pose = engine->KeyframePose(1);
  const Rigid3d new_pose(old_pose.rotation, old_pose.translation + Eigen::Vector3d(0.2, 0, 0));
  engine->UpdateKeyframePose(1, new_pose);
  EXPECT_LT((engine->KeyframePose(1).translation - new_pose.translation).norm(), 1e-12);
  const GaussianCloud after = engine->Map();
  ASSERT_EQ(before.size(), after.size());
  int moved = 0, kept = 0;
  for (int i = 0; i < before.size(); ++i) {
    const double dx = after.means[3 * i] - before.means[3 * i];
    const Eigen::Vector3d shift(dx, after.means[3 * i + 1] - before.means[3 * i + 1],
                                after.means[3 * i + 2] - before.means[3 * i + 2]);
    // cam_from_world translation +0.2 x moves world points by -R^T (0.2, 0, 0).
    const Eigen::Vector3d expected = -(old_pose.rotation.inverse() * Eigen::Vector3d(0.2, 0, 0));
    if (shift.norm() < 1e-6) {
      ++kept;
    } else {
      EXPECT_LT((shift - expected).norm(), 1e-5);
      ++moved;
    }
  }
  EXPECT_GT(moved, 0);
  EXPECT_GT(kept, 0);  // keyframe 0's Gaussians stay
}

// RequestRefine: a synchronous engine runs the steps before it returns; a
// threaded one hands them to its mapping thread and returns at once (a
// million steps would take many minutes on the caller's thread), runs them
// before WaitUntilIdle returns, and stops them when it is destroyed.
TEST(EngineApi, RequestRefineRunsOnTheMappingThread) {
  const SyntheticScene scene(Scene(9));
  for (const bool synchronous : {true, false}) {
    EngineOptions o = Options(scene.camera(), synchronous);
    o.iterations_per_keyframe = 2;
    auto engine = Engine::Create(o);
    for (int i = 0; i < scene.num_frames(); ++i) Push(*engine, scene.Render(i));
    engine->WaitUntilIdle();
    ASSERT_GE(engine->Status().mapped_keyframes, 2);
    const int before = engine->Status().iterations;
    EXPECT_EQ(engine->RequestRefine(20), 20);
    if (synchronous) EXPECT_EQ(engine->Status().iterations, before + 20);
    engine->WaitUntilIdle();
    EXPECT_EQ(engine->Status().iterations, before + 20) << "synchronous " << synchronous;
    EXPECT_THROW(engine->RequestRefine(-1), InvalidInput);
    if (synchronous) continue;
    const int many = 1000000;
    EXPECT_EQ(engine->RequestRefine(many), many);
    EXPECT_LT(engine->Status().iterations, before + 20 + many);
    engine.reset();  // stops the steps: the test ends
  }
}

// With the sensor model on, each keyframe needs the camera's angular
// velocity. Without one from the host the engine differentiates the pushed
// poses (this frame and the one before): the map is the same as with the
// host giving that velocity, and differs from a map made with zero velocity.
TEST(EngineApi, AngularVelocityComesFromThePushedPosesWhenTheHostGivesNone) {
  SynthOptions so = Scene(9);
  so.motion = SynthMotion::kRpy;
  const SyntheticScene scene(so);
  EngineOptions o = Options(scene.camera(), true);
  o.iterations_per_keyframe = 5;
  o.mapper.sensor.readout = 0.03;
  o.mapper.sensor.exposure = 0.02;
  enum class Omega { kDerived, kGiven, kZero };
  auto run = [&](Omega mode) {
    auto engine = Engine::Create(o);
    std::optional<Rigid3d> last;
    double last_t = 0.0, max_rate = 0.0;
    for (int i = 0; i < scene.num_frames(); ++i) {
      const SynthFrame f = scene.Render(i);
      const Rigid3d pose = f.world_from_cam.Inverse();
      FrameBuffers b;
      b.timestamp = f.timestamp;
      b.rgb = f.rgb.data();
      b.depth_m = f.depth_noisy.data();
      const Eigen::Vector3d omega =
          last ? AngularVelocity(*last, last_t, pose, f.timestamp) : Eigen::Vector3d::Zero();
      max_rate = std::max(max_rate, omega.norm());
      if (mode == Omega::kGiven) b.angular_velocity = omega;
      if (mode == Omega::kZero) b.angular_velocity = Eigen::Vector3d::Zero();
      EXPECT_TRUE(engine->PushFrame(b, &pose).has_pose);
      last = pose;
      last_t = f.timestamp;
    }
    EXPECT_GT(max_rate, 0.1) << "the camera should rotate";
    return engine->Map();
  };
  const GaussianCloud derived = run(Omega::kDerived);
  const GaussianCloud given = run(Omega::kGiven);
  const GaussianCloud zero = run(Omega::kZero);
  ASSERT_GT(derived.size(), 0);
  ASSERT_EQ(derived.size(), given.size());
  auto max_diff = [](const std::vector<float>& a, const std::vector<float>& b) {
    if (a.size() != b.size()) return 1e9f;
    float m = 0.0f;
    for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
    return m;
  };
  EXPECT_LT(max_diff(derived.sh, given.sh), 1e-4f);
  EXPECT_LT(max_diff(derived.means, given.means), 1e-5f);
  EXPECT_GT(max_diff(derived.sh, zero.sh), 1e-3f);

  FrameBuffers bad;
  std::vector<uint8_t> rgb(scene.camera().width * scene.camera().height * 3, 0);
  bad.rgb = rgb.data();
  bad.angular_velocity = Eigen::Vector3d(0, std::nan(""), 0);
  auto engine = Engine::Create(o);
  const Rigid3d pose;
  try {
    engine->PushFrame(bad, &pose);
    ADD_FAILURE() << "a NaN angular velocity should be an error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("angular_velocity"), std::string::npos) << e.what();
  }
}

// Mapping much slower than the camera: every keyframe still reaches the
// map. Waiting keyframes beyond the unpacked few are packed, beyond the
// memory limit spilled to the spill folder (removed at the end); without a
// spill folder the pushing thread waits instead.
TEST(EngineApi, ThreadedMappingNeverDropsAKeyframeAndKeepsItsMemoryBound) {
  const SyntheticScene scene(Scene(40));
  for (const bool spill : {true, false}) {
    SCOPED_TRACE(spill ? "with a spill folder" : "without a spill folder");
    EngineOptions o = Options(scene.camera(), false);
    o.keyframes.max_frame_gap = 1;  // every frame is a keyframe
    o.keyframes.min_new_content = 0;
    o.queue_capacity = 2;
    o.waiting_memory_mb = 1;  // a few packed 160x120 keyframes
    o.iterations_per_keyframe = 30;  // much slower than pushing (0.5 s a keyframe against a few ms a frame)
    const std::string dir = ::dypho::testing::TestTempDir() + "/spill";
    if (spill) o.spill_dir = dir;
    auto engine = Engine::Create(o);
    int max_queued = 0;
    for (int i = 0; i < scene.num_frames(); ++i) {
      Push(*engine, scene.Render(i));
      max_queued = std::max(max_queued, engine->QueueStatus().queued_keyframes);
    }
    engine->Finish();
    const EngineStatus s = engine->Status();
    EXPECT_EQ(s.keyframes, 40);
    EXPECT_EQ(s.mapped_keyframes, 40);
    EXPECT_EQ(s.queued_keyframes, 0);
    EXPECT_GT(s.late_keyframes, 0);
    EXPECT_GT(max_queued, 2);
    EXPECT_LE(s.peak_waiting_mb, 1.0);
    if (spill) {
      EXPECT_GT(s.spilled_keyframes, 0);
      EXPECT_EQ(s.push_waits, 0);
    } else {
      EXPECT_EQ(s.spilled_keyframes, 0);
      EXPECT_GT(s.push_waits, 0);
    }
    // Every keyframe has its pose, whether it waited or not.
    for (int id = 0; id < s.keyframes; ++id) {
      const Rigid3d expected = scene.Render(id).world_from_cam.Inverse();
      EXPECT_LT((engine->KeyframePose(id).translation - expected.translation).norm(), 1e-9) << id;
    }
    engine.reset();
    EXPECT_FALSE(std::filesystem::exists(dir));  // spill files and folder removed
  }
}

// Keyframes every few frames: a 3-frame sharpness window, a keyframe at
// least every 5 frames, 2 steps each, no final refinement.
EngineOptions WindowOptions(const Camera& camera, bool synchronous) {
  EngineOptions o = Options(camera, synchronous);
  o.keyframes.sharpness_window = 3;
  o.keyframes.max_frame_gap = 5;
  o.iterations_per_keyframe = 2;
  o.final_iterations = 0;
  return o;
}

// The keyframe is the sharpest frame of a window: PushResult names it by
// timestamp, and Finish maps a candidate whose window was still open.
TEST(EngineApi, SharpnessWindowNamesTheChosenFrameAndFinishMapsTheLastCandidate) {
  const SyntheticScene scene(Scene(12));
  EngineOptions o = WindowOptions(scene.camera(), true);
  auto engine = Engine::Create(o);
  int reported = 0;
  std::vector<double> pushed;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const SynthFrame f = scene.Render(i);
    pushed.push_back(f.timestamp);
    const PushResult r = Push(*engine, f);
    if (!r.keyframe) continue;
    EXPECT_EQ(r.keyframe_id, reported++);
    EXPECT_LE(r.keyframe_timestamp, f.timestamp);
    EXPECT_GE(r.keyframe_timestamp, pushed[std::max(0, i - 2)]);  // within the window of 3
    EXPECT_NEAR(engine->KeyframePose(r.keyframe_id).Inverse().translation.x(),
                InterpolatePose(scene.trajectory(), r.keyframe_timestamp, 1.0)->translation.x(), 1e-9);
  }
  EXPECT_GE(reported, 2);
  engine->Finish();
  const EngineStatus s = engine->Status();
  EXPECT_GE(s.keyframes, reported);
  EXPECT_LE(s.keyframes, reported + 1);
  EXPECT_EQ(s.mapped_keyframes, s.keyframes);
}

// The end of the stream: with the content and motion rules out of reach,
// only the first frame is a keyframe while frames come; Finish makes the
// newest frame that saw new content (the tail candidate) a keyframe too, so
// the view the camera ended on is in the map.
TEST(EngineApi, FinishMapsTheNewContentOfTheLastFrames) {
  const SyntheticScene scene(Scene(12));
  for (const double tail : {0.02, 0.0}) {
    EngineOptions o = WindowOptions(scene.camera(), true);
    o.keyframes.sharpness_window = 1;
    o.keyframes.max_frame_gap = 1000;
    o.keyframes.max_translation = 100.0;
    o.keyframes.max_rotation_deg = 179.0;
    o.keyframes.min_new_content = 0.9;
    o.keyframes.tail_new_content = tail;
    auto engine = Engine::Create(o);
    double last = 0.0;
    for (int i = 0; i < scene.num_frames(); ++i) {
      const SynthFrame f = scene.Render(i);
      last = f.timestamp;
      EXPECT_EQ(Push(*engine, f).keyframe, i == 0) << i;
    }
    engine->Finish();
    const Trajectory kf = engine->MappedKeyframes();
    ASSERT_EQ(kf.timestamps.size(), tail > 0 ? 2u : 1u) << tail;
    EXPECT_EQ(kf.timestamps.front(), scene.Render(0).timestamp);
    if (tail > 0) EXPECT_EQ(kf.timestamps.back(), last);  // the camera keeps moving: the last frame is the newest
    EXPECT_EQ(engine->Status().mapped_keyframes, static_cast<int>(kf.timestamps.size()));
  }
}

// EngineOptions::keyframe_mask: asked once for each keyframe (the chosen
// frame of its sharpness window, with the pixels it was pushed with); what
// it returns is kept out of the map. Here it masks everything for every
// second keyframe: those keyframes add no Gaussians.
TEST(EngineApi, KeyframeMaskHookSeesEachKeyframeAndKeepsItsPixelsOutOfTheMap) {
  const SyntheticScene scene(Scene(12));
  EngineOptions o = WindowOptions(scene.camera(), true);
  std::vector<double> asked;
  std::vector<bool> rgb_matches;
  o.keyframe_mask = [&](const KeyframeMaskRequest& r) {
    asked.push_back(r.timestamp);
    int frame = -1;
    for (int i = 0; i < scene.num_frames(); ++i)
      if (scene.Render(i).timestamp == r.timestamp) frame = i;
    const SynthFrame f = scene.Render(std::max(frame, 0));
    rgb_matches.push_back(frame >= 0 && r.width == scene.camera().width && r.height == scene.camera().height &&
                          std::equal(f.rgb.data(), f.rgb.data() + f.rgb.size(), r.rgb) && r.depth_m != nullptr &&
                          r.dynamic_mask != nullptr);
    const bool mask_all = asked.size() % 2 == 0;
    return std::vector<uint8_t>(mask_all ? static_cast<size_t>(r.width) * r.height : 0, 255);
  };
  auto engine = Engine::Create(o);
  std::vector<double> keyframes;
  std::vector<int> gaussians_after;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const PushResult r = Push(*engine, scene.Render(i));
    if (!r.keyframe) continue;
    keyframes.push_back(r.keyframe_timestamp);
    gaussians_after.push_back(engine->Status().num_gaussians);
  }
  engine->Finish();
  ASSERT_GE(keyframes.size(), 2u);
  ASSERT_GE(asked.size(), keyframes.size());  // Finish may map one more
  for (size_t k = 0; k < keyframes.size(); ++k) EXPECT_EQ(asked[k], keyframes[k]) << k;
  for (bool m : rgb_matches) EXPECT_TRUE(m);
  EXPECT_GT(gaussians_after[0], 100);                  // keyframe 1: its own mask only
  EXPECT_EQ(gaussians_after[1], gaussians_after[0]);   // keyframe 2: all masked, nothing added
}

// Threaded, the hook runs on the mapping thread, never inside PushFrame
// (the tracking thread does not wait for a detector), once per keyframe;
// what it returns is kept out of the map as in the synchronous engine.
TEST(EngineApi, KeyframeMaskHookRunsOffThePushingThread) {
  const SyntheticScene scene(Scene(12));
  EngineOptions o = WindowOptions(scene.camera(), false);
  std::mutex mutex;
  std::vector<double> asked;
  std::vector<std::thread::id> threads;
  o.keyframe_mask = [&](const KeyframeMaskRequest& r) {
    std::lock_guard<std::mutex> lock(mutex);
    asked.push_back(r.timestamp);
    threads.push_back(std::this_thread::get_id());
    return std::vector<uint8_t>(static_cast<size_t>(r.width) * r.height, 255);  // everything dynamic
  };
  auto engine = Engine::Create(o);
  std::vector<double> keyframes;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const PushResult r = Push(*engine, scene.Render(i));
    if (r.keyframe) keyframes.push_back(r.keyframe_timestamp);
  }
  engine->Finish();
  const EngineStatus s = engine->Status();
  ASSERT_GE(keyframes.size(), 2u);
  EXPECT_EQ(s.mapped_keyframes, s.keyframes);
  EXPECT_EQ(static_cast<int>(asked.size()), s.keyframes);
  for (size_t k = 0; k < keyframes.size(); ++k) EXPECT_EQ(asked[k], keyframes[k]) << k;
  for (const std::thread::id& id : threads) EXPECT_NE(id, std::this_thread::get_id());
  EXPECT_EQ(s.keyframe_masks, s.keyframes);
  EXPECT_EQ(s.keyframe_masks_on_push, 0);
  EXPECT_EQ(s.num_gaussians, 0) << "every keyframe fully masked: nothing mapped";
}

TEST(EngineApi, ConcurrentPushRenderAndPoseUpdates) {
  const SyntheticScene scene(Scene(30));
  EngineOptions o = Options(scene.camera(), false);
  o.queue_capacity = 64;  // room for every keyframe unpacked: this test is about concurrent calls
  auto engine = Engine::Create(o);
  std::atomic<bool> done{false};
  std::atomic<int> renders{0};
  std::thread viewer([&] {
    while (!done) {
      const EngineRender r = engine->Render(scene.camera(), scene.Render(0).world_from_cam.Inverse());
      EXPECT_EQ(r.color.size(), 160u * 120u * 3u);
      const EngineStatus s = engine->Status();
      if (s.mapped_keyframes > 1) engine->UpdateKeyframePose(1, engine->KeyframePose(1));  // a no-op correction
      ++renders;
    }
  });
  for (int i = 0; i < scene.num_frames(); ++i) Push(*engine, scene.Render(i));
  engine->Finish();
  done = true;
  viewer.join();
  EXPECT_GT(renders.load(), 0);
  EXPECT_EQ(engine->Status().mapped_keyframes, engine->Status().keyframes);
  EXPECT_GT(RenderPsnr(*engine, scene, 15), 20.0);
}

TEST(EngineApi, BadInputIsAClearError) {
  const SyntheticScene scene(Scene(2));
  EngineOptions o = Options(scene.camera(), true);
  o.queue_capacity = 0;
  EXPECT_INVALID_INPUT(Engine::Create(o), "queue_capacity");
  o = Options(scene.camera(), true);
  o.camera.fx = -1;
  EXPECT_INVALID_INPUT(Engine::Create(o), "camera");
  auto engine = Engine::Create(Options(scene.camera(), true));
  const SynthFrame f = scene.Render(0);
  FrameBuffers b;
  EXPECT_INVALID_INPUT(engine->PushFrame(b), "rgb");
  b.rgb = f.rgb.data();
  std::vector<uint16_t> depth16(160 * 120, 5000);
  b.depth = depth16.data();
  b.depth_m = f.depth.data();
  EXPECT_INVALID_INPUT(engine->PushFrame(b), "not both");
  b.depth_m = nullptr;
  EXPECT_INVALID_INPUT(engine->PushFrame(b), "no pose");  // tracker off, no pose
  Rigid3d nan_pose;
  nan_pose.translation.x() = std::nan("");
  EXPECT_INVALID_INPUT(engine->PushFrame(b, &nan_pose), "not finite");
  EXPECT_INVALID_INPUT(engine->KeyframePose(0), "no keyframe 0");
  EXPECT_INVALID_INPUT(engine->UpdateKeyframePose(0, nan_pose), "not finite");
  // An empty map renders transparent, not a crash.
  const EngineRender r = engine->Render(scene.camera(), Rigid3d());
  for (float a : r.alpha) ASSERT_EQ(a, 0.0f);
}

}  // namespace
}  // namespace dypho
