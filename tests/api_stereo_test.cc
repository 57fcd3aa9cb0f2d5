// Stereo pairs through the embedding API (FrameBuffers::right_rgb): the engine
// computes the depth of a rectified pair itself, exactly as the stereo
// datasets' frame loader does, and bad stereo input is a clear error.
#include <gtest/gtest.h>

#include <string>

#include "common/check.h"
#include "engine/api.h"
#include "engine/dataset/dataset.h"
#include "engine/stereo/rig.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

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
  EngineOptions distorted = StereoOptions(*dataset);
  distorted.camera.distortion[0] = 0.1;
  expect_error([&] { Engine::Create(distorted); }, "stereo_baseline");
  EngineOptions bad_method = StereoOptions(*dataset);
  bad_method.stereo_method = "bm";
  expect_error([&] { Engine::Create(bad_method); }, "stereo_method");
}

}  // namespace
}  // namespace dypho
