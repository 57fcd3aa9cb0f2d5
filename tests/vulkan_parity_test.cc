// Vulkan renderer against the CPU reference rasterizer on lavapipe (or any
// Vulkan device): both compositing modes, random Gaussians with SH degree 3,
// the demo scene and a map from a real TUM frame; edge cases. Runs with the
// Khronos validation layer when it is installed and requires that it
// reports nothing.
//
// Written tolerances (see engine/vulkan/vulkan_renderer.h for why the two
// differ at all):
//   colour PSNR >= 35 dB (the bound) on every scene and mode;
//   normalised depth (depth / alpha) within 1% of the CPU's on pixels where
//   both alphas exceed 0.5: at least 99.9% of them (cut-off boundary pixels
//   may flip in the last float bit of the conic);
//   visible-Gaussian counts equal within 0.1%.
#include <cmath>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "engine/dataset/dataset.h"
#include "engine/render/demo_scene.h"
#include "engine/render/render.h"
#include "engine/vulkan/vk_context.h"
#include "engine/vulkan/vulkan_renderer.h"
#include "tests/test_data.h"
#include "tests/vulkan_test_scenes.h"

namespace dypho {
namespace {

using kernels::CompositeMode;
using testing::CompareDepth;
using testing::Psnr;

constexpr double kMinPsnr = 35.0;     // the bound, both modes
constexpr double kMinPsnrOit = 60.0;  // OIT has no early stop to differ by: only float rounding
constexpr double kDepthRel = 0.01;
constexpr double kDepthFraction = 0.999;

// One renderer (one device) for the whole file; validation on when installed.
vulkan::VulkanRenderer& Renderer() {
  static std::unique_ptr<vulkan::VulkanRenderer> renderer = [] {
    vulkan::VulkanRendererOptions options;
    options.validation = true;
    auto r = std::make_unique<vulkan::VulkanRenderer>(options);
    std::printf("Vulkan device %s, validation layer %s\n", r->device_description().c_str(),
                r->validation_enabled() ? "on" : "not installed");
    return r;
  }();
  return *renderer;
}

class VulkanParity : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (!vulkan::VulkanAvailable(&why)) {
      if (testing::InCi()) FAIL() << "Vulkan is required in CI: " << why;
      GTEST_SKIP() << why;
    }
    Renderer();
  }
  // Any validation message since the renderer was created (including its
  // pipelines) fails the test in which it shows up.
  void TearDown() override {
    if (IsSkipped()) return;
    EXPECT_EQ(Renderer().validation_messages(), 0) << "Vulkan validation layer reported problems";
  }

  // Renders `cloud` on both backends in `mode` and checks the tolerances.
  void ExpectParity(const GaussianCloud& cloud, const Camera& camera, const Rigid3d& pose, CompositeMode mode,
                    const std::string& what) {
    kernels::RasterSettings settings;
    settings.mode = mode;
    settings.background[0] = 0.2f;
    settings.background[1] = 0.1f;
    settings.background[2] = 0.3f;
    const RenderedView cpu = RenderView(cloud, camera, pose, settings);
    Renderer().SetMap(cloud);
    const RenderedView gpu = Renderer().Render(camera, pose, settings);
    const double psnr = Psnr(gpu.color, cpu.color);
    const auto depth = CompareDepth(gpu, cpu, kDepthRel);
    const double max_alpha = testing::MaxAbsDiff(gpu.alpha, cpu.alpha);
    ::testing::Test::RecordProperty(what + "_psnr", std::to_string(psnr));
    std::printf("%-28s %-16s PSNR %.1f dB, depth within 1%%: %d/%d (max %.2g), max |alpha diff| %.3g, visible %d/%d\n",
                what.c_str(), kernels::CompositeModeName(mode), psnr, depth.within, depth.compared, depth.max_rel,
                max_alpha, gpu.stats.num_visible, cpu.stats.num_visible);
    EXPECT_GE(psnr, kMinPsnr) << what;
    if (mode == CompositeMode::kOrderIndependent) EXPECT_GE(psnr, kMinPsnrOit) << what;
    ASSERT_GT(depth.compared, 0) << what << ": nothing opaque to compare";
    EXPECT_GE(depth.within, kDepthFraction * depth.compared) << what << " max rel " << depth.max_rel;
    EXPECT_NEAR(gpu.stats.num_visible, cpu.stats.num_visible, 1 + 0.001 * cpu.stats.num_visible) << what;
    EXPECT_EQ(gpu.stats.num_nonfinite, cpu.stats.num_nonfinite) << what;
  }
};

Camera TestCamera(int w, int h) { return Camera{0.9 * w, 0.9 * w, 0.5 * (w - 1) + 3.25, 0.5 * (h - 1) - 2.5, w, h}; }

TEST_F(VulkanParity, RandomGaussiansShDegree3BothModes) {
  const GaussianCloud cloud = testing::RandomCloud(3000, 16, 7);
  const Rigid3d pose(Eigen::Quaterniond(Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.3, 1, 0.2).normalized())),
                     Eigen::Vector3d(0.05, -0.02, 0.1));
  for (auto mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    ExpectParity(cloud, TestCamera(320, 240), pose, mode, "random 3000 sh3");
  }
}

TEST_F(VulkanParity, RandomGaussiansLowShDegreesAndOddSize) {
  for (int coeffs : {1, 4, 9}) {
    const GaussianCloud cloud = testing::RandomCloud(1500, coeffs, 11 + coeffs);
    for (auto mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
      ExpectParity(cloud, TestCamera(173, 131), Rigid3d(), mode, "random 1500 K=" + std::to_string(coeffs));
    }
  }
}

TEST_F(VulkanParity, DemoScene) {
  const GaussianCloud cloud = MakeDemoScene();
  for (auto mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    ExpectParity(cloud, DemoCamera(320, 240), DemoCamFromWorld(0.4), mode, "demo scene");
  }
}

TEST_F(VulkanParity, MapFromRealTumFrame) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  auto dataset = OpenDataset(testing::SharedData("tum_fr1_rpy_head250"));
  const Frame frame = dataset->Load(0);
  ASSERT_TRUE(frame.has_depth);
  const Camera camera = dataset->camera();
  const GaussianCloud cloud = testing::CloudFromFrame(frame, camera, 2);
  ASSERT_GT(cloud.size(), 30000);
  // A slightly moved pose: 3 cm sideways, 2 degrees of yaw.
  const Rigid3d cam_from_world(Eigen::Quaterniond(Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitY())),
                               Eigen::Vector3d(0.03, 0.0, 0.01));
  for (auto mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    ExpectParity(cloud, camera, cam_from_world, mode, "TUM fr1 frame 0 (2x2)");
  }
}

// 600k Gaussians (a third outside the view): the radix sort runs with more
// keys per thread than the minimum (256) and hundreds of threads; only the
// visible ones are drawn (indirect draw), in depth order or, for OIT, in
// index order.
TEST_F(VulkanParity, LargeMapSortsLikeTheCpu) {
  GaussianCloud cloud = testing::RandomCloud(600000, 1, 21);
  for (float& s : cloud.log_scales) s -= 2.0f;  // small splats keep the CPU reference quick
  const Camera camera = TestCamera(160, 120);
  for (auto mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    ExpectParity(cloud, camera, Rigid3d(), mode, "random 600k");
  }
}

// The sort keeps index order for equal depths, like the CPU's stable sort:
// two coincident Gaussians of different colour give the CPU's colour.
TEST_F(VulkanParity, EqualDepthsKeepIndexOrder) {
  GaussianCloud cloud;
  const float mean[3] = {0, 0, 2};
  const float ls[3] = {std::log(0.2f), std::log(0.2f), std::log(0.2f)};
  const float q[4] = {1, 0, 0, 0};
  const float red[3] = {RgbToShDc(1), RgbToShDc(0), RgbToShDc(0)};
  const float blue[3] = {RgbToShDc(0), RgbToShDc(0), RgbToShDc(1)};
  for (int i = 0; i < 300; ++i) cloud.Add(mean, ls, q, 1.0f, i % 2 ? blue : red);
  kernels::RasterSettings settings;
  const Camera camera = TestCamera(64, 48);
  const RenderedView cpu = RenderView(cloud, camera, Rigid3d(), settings);
  Renderer().SetMap(cloud);
  const RenderedView gpu = Renderer().Render(camera, Rigid3d(), settings);
  // Centre pixel: red first (index 0), its weight dominates.
  const int cx = 32, cy = 24;
  EXPECT_GT(cpu.color.at(cx, cy, 0), cpu.color.at(cx, cy, 2));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(gpu.color.at(cx, cy, c), cpu.color.at(cx, cy, c), 2e-3) << c;
}

TEST_F(VulkanParity, EmptyMapRendersBackground) {
  Renderer().SetMap(GaussianCloud{});
  kernels::RasterSettings settings;
  settings.background[0] = 0.25f;
  settings.background[1] = 0.5f;
  settings.background[2] = 0.75f;
  for (auto mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    settings.mode = mode;
    const RenderedView v = Renderer().Render(TestCamera(40, 30), Rigid3d(), settings);
    EXPECT_EQ(v.stats.num_visible, 0);
    for (int y = 0; y < 30; ++y) {
      for (int x = 0; x < 40; ++x) {
        ASSERT_EQ(v.alpha.at(x, y), 0.0f);
        ASSERT_EQ(v.depth.at(x, y), 0.0f);
        for (int c = 0; c < 3; ++c) ASSERT_EQ(v.color.at(x, y, c), settings.background[c]);
      }
    }
  }
}

TEST_F(VulkanParity, NonFiniteEntriesAreCulledLikeTheCpu) {
  GaussianCloud cloud = testing::RandomCloud(800, 4, 3);
  const float nan = std::nanf(""), inf = INFINITY;
  cloud.means[3 * 5 + 1] = nan;
  cloud.log_scales[3 * 17] = -inf;
  cloud.quats[4 * 40 + 2] = nan;
  cloud.opacity_logits[77] = nan;
  cloud.sh[3 * 4 * 90 + 7] = inf;
  for (int k = 0; k < 4; ++k) cloud.quats[4 * 120 + k] = 0.0f;  // zero quaternion
  for (auto mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    ExpectParity(cloud, TestCamera(160, 120), Rigid3d(), mode, "non-finite entries");
  }
  kernels::RasterSettings settings;
  Renderer().SetMap(cloud);
  EXPECT_EQ(Renderer().Render(TestCamera(160, 120), Rigid3d(), settings).stats.num_nonfinite, 6);
}

TEST_F(VulkanParity, ExtremeIntrinsicsMatchOrStayFinite) {
  const GaussianCloud cloud = testing::RandomCloud(500, 1, 5);
  // Very long and very short focal lengths, principal point far off-centre.
  for (double f : {5.0, 20000.0}) {
    Camera c = TestCamera(96, 64);
    c.fx = c.fy = f;
    c.cx = -40.0;
    kernels::RasterSettings settings;
    Renderer().SetMap(cloud);
    const RenderedView gpu = Renderer().Render(c, Rigid3d(), settings);
    const RenderedView cpu = RenderView(cloud, c, Rigid3d(), settings);
    for (float v : gpu.color.pixels()) ASSERT_TRUE(std::isfinite(v));
    EXPECT_GE(Psnr(gpu.color, cpu.color), kMinPsnr) << "f = " << f;
  }
}

TEST_F(VulkanParity, BadCamerasAreClearErrors) {
  Renderer().SetMap(testing::RandomCloud(10, 1, 1));
  kernels::RasterSettings settings;
  Camera empty = TestCamera(64, 48);
  empty.width = 0;
  EXPECT_INVALID_INPUT(Renderer().Render(empty, Rigid3d(), settings), "width");
  Camera c = TestCamera(64, 48);
  c.fx = 0;
  EXPECT_INVALID_INPUT(Renderer().Render(c, Rigid3d(), settings), "fx");
  EXPECT_INVALID_INPUT(Renderer().Render(TestCamera(20000, 4), Rigid3d(), settings), "limit");
  settings.near_plane = -1;
  EXPECT_INVALID_INPUT(Renderer().Render(TestCamera(64, 48), Rigid3d(), settings), "near");
  // Mismatched arrays name the map.
  GaussianCloud bad = testing::RandomCloud(10, 1, 1);
  bad.quats.pop_back();
  EXPECT_INVALID_INPUT(Renderer().SetMap(bad), "quats");
}

}  // namespace
}  // namespace dypho
