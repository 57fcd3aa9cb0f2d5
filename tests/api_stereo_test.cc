// Stereo pairs through the embedding API (FrameBuffers::right_rgb): the engine
// computes the depth of a rectified pair itself, exactly as the stereo
// datasets' frame loader does, for every frame or (keyframe_depth_from_pair)
// for keyframes only, and bad stereo input is a clear error.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "common/check.h"
#include "engine/api.h"
#include "engine/dataset/dataset.h"
#include "engine/stereo/rig.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

EngineOptions StereoOptions(const Dataset& dataset) {
  EngineOptions o;
  o.camera = dataset.camera();
  o.mapper.train_downscale = 4;
  o.mapper.sh_degree = 0;
  o.mapper.num_threads = 2;
  o.mapper.densify_every = 0;
  o.mapper.min_depth = 1;
  o.mapper.max_depth = 25;
  o.keyframes.max_frame_gap = 2;
  o.keyframes.sharpness_window = 1;
  o.keyframes.min_new_content = 0;
  o.iterations_per_keyframe = 5;
  o.final_iterations = 10;
  o.carve_votes = 0;
  o.synchronous = true;
  o.track_when_no_pose = false;
  o.stereo_baseline = dataset.stereo()->baseline;
  return o;
}

// Four KITTI frames pushed as pairs and as the dataset loader's depth give the same map.
TEST(ApiStereo, PairsGiveTheSameMapAsTheDatasetDepth) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const auto dataset = OpenDataset(testing::SharedData("kitti_stereo_51"));
  ASSERT_NE(dataset->stereo(), nullptr);
  auto pairs = Engine::Create(StereoOptions(*dataset));
  auto depths = Engine::Create(StereoOptions(*dataset));
  int keyframes = 0;
  for (size_t i = 0; i < 4; ++i) {
    const Frame f = dataset->Load(i);
    ASSERT_FALSE(f.right.empty());
    const Rigid3d pose = f.world_from_cam_gt->Inverse();
    FrameBuffers a;
    a.timestamp = f.timestamp;
    a.rgb = f.rgb.data();
    a.right_rgb = f.right.data();
    FrameBuffers b = a;
    b.right_rgb = nullptr;
    b.depth_m = f.depth.data();
    const PushResult ra = pairs->PushFrame(a, &pose), rb = depths->PushFrame(b, &pose);
    EXPECT_EQ(ra.keyframe, rb.keyframe) << "frame " << i;
    keyframes += ra.keyframe;
  }
  pairs->Finish();
  depths->Finish();
  const GaussianCloud ma = pairs->Map(), mb = depths->Map();
  EXPECT_GE(keyframes, 2);
  ASSERT_GT(ma.size(), 1000u);
  EXPECT_EQ(ma.means, mb.means);
  EXPECT_EQ(ma.sh, mb.sh);
}

// A preview depth (the pair at half resolution) for the keyframe choice and
// the pair for the keyframes' dense depth give the map of the full depth
// pushed for every frame, bit for bit (the keyframe rules here depend on the
// poses only), the dense map too; the engine computes exactly one dense
// disparity per keyframe. In threaded mode the mapping thread computes them.
void PushPreviewAndFull(Engine* lazy, Engine* eager, const Dataset& full, const Dataset& preview, size_t frames,
                        int* keyframes) {
  for (size_t i = 0; i < frames; ++i) {
    const Frame f = full.Load(i), p = preview.Load(i);
    ASSERT_EQ(p.depth_downscale, 2);
    ASSERT_EQ(f.rgb.pixels(), p.rgb.pixels());
    const Rigid3d pose = f.world_from_cam_gt->Inverse();
    FrameBuffers a;
    a.timestamp = f.timestamp;
    a.rgb = p.rgb.data();
    a.right_rgb = p.right.data();
    a.depth_m = p.depth.data();
    a.keyframe_depth_from_pair = true;
    const PushResult ra = lazy->PushFrame(a, &pose);
    if (eager) {
      FrameBuffers b;
      b.timestamp = f.timestamp;
      b.rgb = f.rgb.data();
      b.depth_m = f.depth.data();
      EXPECT_EQ(ra.keyframe, eager->PushFrame(b, &pose).keyframe) << "frame " << i;
    }
    *keyframes += ra.keyframe;
  }
}

TEST(ApiStereo, PreviewDepthAndPairGiveTheEagerMapWithOneDisparityPerKeyframe) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const auto full = OpenDataset(testing::SharedData("kitti_stereo_51"));
  const Dataset preview = full->WithStereoPreview(2);
  EngineOptions o = StereoOptions(*full);
  o.dense.enabled = true;
  o.dense.points.min_depth = 1;  // the KITTI road and cars, as the stereo preset's map
  o.dense.points.max_depth = 25;
  o.dense.map.voxel_size = 0.1;
  auto lazy = Engine::Create(o), eager = Engine::Create(o);
  int keyframes = 0;
  PushPreviewAndFull(lazy.get(), eager.get(), *full, preview, 5, &keyframes);
  lazy->Finish();
  eager->Finish();
  EXPECT_GE(keyframes, 3);
  EXPECT_EQ(lazy->Status().keyframe_pair_depths, keyframes);
  EXPECT_GT(lazy->Status().keyframe_pair_depth_ms, 0.0);
  EXPECT_EQ(eager->Status().keyframe_pair_depths, 0);
  const GaussianCloud ma = lazy->Map(), mb = eager->Map();
  ASSERT_GT(ma.size(), 1000);
  EXPECT_EQ(ma.means, mb.means);
  EXPECT_EQ(ma.sh, mb.sh);
  EXPECT_EQ(ma.opacity_logits, mb.opacity_logits);
  EXPECT_EQ(ma.log_scales, mb.log_scales);
  const DenseMapStats da = lazy->DenseStatus(), db = eager->DenseStatus();
  EXPECT_EQ(da.keyframes_added, keyframes);
  EXPECT_GT(da.map.voxels, 1000);
  EXPECT_EQ(da.map.voxels, db.map.voxels);
  EXPECT_EQ(da.map.stored_points, db.map.stored_points);
  const std::string dir = std::string(DYPHO_BINARY_DIR) + "/test_tmp/api_stereo_preview";
  std::filesystem::create_directories(dir);
  lazy->SaveDenseCloud(dir + "/lazy.ply");
  eager->SaveDenseCloud(dir + "/eager.ply");
  EXPECT_EQ(ReadBytes(dir + "/lazy.ply"), ReadBytes(dir + "/eager.ply"));

  // Threaded: the mapping thread computes them (one per keyframe).
  o.synchronous = false;
  o.dense.enabled = false;
  auto threaded = Engine::Create(o);
  int threaded_keyframes = 0;
  PushPreviewAndFull(threaded.get(), nullptr, *full, preview, 5, &threaded_keyframes);
  threaded->Finish();
  EXPECT_EQ(threaded_keyframes, keyframes);
  EXPECT_EQ(threaded->Status().keyframe_pair_depths, keyframes);
}

TEST(ApiStereo, BadStereoInputIsAClearError) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const auto dataset = OpenDataset(testing::SharedData("kitti_stereo_51"));
  const Frame f = dataset->Load(0);
  const Rigid3d pose;
  auto expect_error = [](const std::function<void()>& call, const std::string& needle) {
    try {
      call();
      ADD_FAILURE() << "no error; expected one naming " << needle;
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  EngineOptions no_baseline = StereoOptions(*dataset);
  no_baseline.stereo_baseline = 0;
  auto engine = Engine::Create(no_baseline);
  FrameBuffers b;
  b.timestamp = f.timestamp;
  b.rgb = f.rgb.data();
  b.right_rgb = f.right.data();
  expect_error([&] { engine->PushFrame(b, &pose); }, "stereo_baseline");
  auto stereo = Engine::Create(StereoOptions(*dataset));
  b.depth_m = f.depth.data();
  expect_error([&] { stereo->PushFrame(b, &pose); }, "right_rgb");
  FrameBuffers no_pair = b;
  no_pair.right_rgb = nullptr;
  no_pair.keyframe_depth_from_pair = true;
  expect_error([&] { stereo->PushFrame(no_pair, &pose); }, "keyframe_depth_from_pair");
  expect_error([&] { dataset->WithStereoPreview(9); }, "1..8");
  EngineOptions distorted = StereoOptions(*dataset);
  distorted.camera.distortion[0] = 0.1;
  expect_error([&] { Engine::Create(distorted); }, "stereo_baseline");
  EngineOptions bad_method = StereoOptions(*dataset);
  bad_method.stereo_method = "bm";
  expect_error([&] { Engine::Create(bad_method); }, "stereo_method");
}

}  // namespace
}  // namespace dypho
