// Offline rendering (engine/render/offline_render.h): intrinsics parsing,
// orbit poses, the written PNGs and poses read back independently, and the
// Vulkan backend writing the same frames as the CPU one.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "engine/eval/trajectory.h"
#include "engine/export/ply.h"
#include "engine/render/demo_scene.h"
#include "engine/render/offline_render.h"
#include "engine/io/image_io.h"
#include "tests/test_data.h"
#include "tests/vulkan_test_scenes.h"
#if defined(DYPHO_WITH_VULKAN)
#include "engine/vulkan/vulkan_renderer.h"
#endif

namespace dypho {
namespace {

TEST(RenderOffline, ParsesIntrinsicsTextAndFiles) {
  const Camera c = ParseIntrinsics("525,526.5,319.5, 239.5,640,480");
  EXPECT_EQ(c.fx, 525.0);
  EXPECT_EQ(c.fy, 526.5);
  EXPECT_EQ(c.cx, 319.5);
  EXPECT_EQ(c.cy, 239.5);
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  const std::string dir = testing::TestTempDir();
  std::ofstream(dir + "/camera.yaml") << "fx: 100\nfy: 101\ncx: 50\ncy: 40\nwidth: 99\nheight: 77\n";
  const Camera f = ParseIntrinsics(dir + "/camera.yaml");
  EXPECT_EQ(f.fy, 101.0);
  EXPECT_EQ(f.width, 99);
  EXPECT_INVALID_INPUT(ParseIntrinsics("525,525,319.5,239.5,640"), "expected 6 values");
  EXPECT_INVALID_INPUT(ParseIntrinsics("525,abc,319.5,239.5,640,480"), "\"abc\" is not a number");
  EXPECT_INVALID_INPUT(ParseIntrinsics("525,525,319.5,239.5,640.5,480"), "whole numbers");
  EXPECT_INVALID_INPUT(ParseIntrinsics("0,525,319.5,239.5,640,480"), "fx");
  EXPECT_INVALID_INPUT(ParseIntrinsics(""), "empty");
}

TEST(RenderOffline, LookAtPointsTheOpticalAxisAtTheTarget) {
  const Eigen::Vector3d pos(1, -2, 3), target(0.5, 0.25, -1), up(0, 0, 1);
  const Rigid3d world_from_cam = LookAt(pos, target, up);
  const Eigen::Vector3d in_cam = world_from_cam.Inverse() * target;
  EXPECT_NEAR(in_cam.x(), 0, 1e-12);
  EXPECT_NEAR(in_cam.y(), 0, 1e-12);
  EXPECT_NEAR(in_cam.z(), (target - pos).norm(), 1e-12);
  // Image y (down) has no component along +up.
  const Eigen::Vector3d y_world = world_from_cam.rotation * Eigen::Vector3d::UnitY();
  EXPECT_LT(y_world.dot(up), 0.0);
  EXPECT_NEAR((world_from_cam.rotation * Eigen::Vector3d::UnitX()).dot(up), 0, 1e-12);
}

TEST(RenderOffline, OrbitCirclesTheMedianCentre) {
  GaussianCloud cloud;
  const float ls[3] = {-3, -3, -3}, q[4] = {1, 0, 0, 0}, sh[3] = {0, 0, 0};
  // Median centre (1, 2, 3); an outlier must not move it.
  const float pts[5][3] = {{0, 2, 3}, {1, 1, 3}, {1, 2, 3}, {2, 3, 4}, {100, 100, 100}};
  for (const auto& p : pts) cloud.Add(p, ls, q, 0, sh);
  OrbitOptions o;
  o.frames = 12;
  o.radius = 2.5;
  o.elevation = 0.2;
  const Trajectory path = OrbitPath(cloud, o);
  ASSERT_EQ(path.size(), 12u);
  const Eigen::Vector3d centre(1, 2, 3);
  for (size_t i = 0; i < path.size(); ++i) {
    EXPECT_NEAR((path.world_from_cam[i].translation - centre).norm(), 2.5, 1e-9);
    const Eigen::Vector3d c = path.world_from_cam[i].Inverse() * centre;
    EXPECT_NEAR(c.x(), 0, 1e-9);
    EXPECT_NEAR(c.y(), 0, 1e-9);
    // Height above the orbit plane: radius sin(elevation) along up = -y.
    EXPECT_NEAR(-(path.world_from_cam[i].translation - centre).y(), 2.5 * std::sin(0.2), 1e-9);
    EXPECT_NEAR(path.timestamps[i], i / 30.0, 1e-12);
  }
  // Consecutive views are 30 degrees apart around the up axis.
  const Eigen::Vector3d d0 = path.world_from_cam[0].translation - centre;
  const Eigen::Vector3d d1 = path.world_from_cam[1].translation - centre;
  const double cos_angle =
      (d0.x() * d1.x() + d0.z() * d1.z()) / (std::hypot(d0.x(), d0.z()) * std::hypot(d1.x(), d1.z()));
  EXPECT_NEAR(cos_angle, std::cos(M_PI / 6), 1e-9);

  o.radius = 0;  // automatic: 2 x 80th percentile distance (sorted: 0, 1, 1, 1.73, 169.8 -> index 4)
  EXPECT_NEAR((OrbitPath(cloud, o).world_from_cam[0].translation - centre).norm(),
              2.0 * Eigen::Vector3d(99, 98, 97).norm(), 1e-6);
  EXPECT_INVALID_INPUT(OrbitPath(GaussianCloud{}, o), "no Gaussian");
  o.frames = 0;
  EXPECT_INVALID_INPUT(OrbitPath(cloud, o), "frames");
}

TEST(RenderOffline, WritesColourDepthAndPosesThatReadBack) {
  const GaussianCloud cloud = MakeDemoScene();
  const Camera camera = DemoCamera(96, 72);
  Trajectory path;
  path.Add(0.0, DemoCamFromWorld(0.0).Inverse());
  path.Add(0.5, DemoCamFromWorld(0.3).Inverse());
  OfflineRenderOptions options;
  options.settings.background[1] = 0.5f;
  const std::string dir = testing::TestTempDir() + "/out";
  const OfflineRenderSummary summary = RenderPath(camera, path, dir, options, CpuViewRenderer(cloud));
  EXPECT_EQ(summary.frames, 2);
  for (int f = 0; f < 2; ++f) {
    const RenderedView ref = RenderView(cloud, camera, path.world_from_cam[f].Inverse(), options.settings);
    char name[64];
    std::snprintf(name, sizeof(name), "/color_%06d.png", f);
    // Read with OpenCV directly (BGR, 8 bit), not through dypho's reader.
    const cv::Mat color = cv::imread(dir + name, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(color.type(), CV_8UC3);
    ASSERT_EQ(color.cols, 96);
    std::snprintf(name, sizeof(name), "/depth_%06d.png", f);
    const cv::Mat depth = cv::imread(dir + name, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(depth.type(), CV_16UC1);
    int opaque = 0;
    for (int y = 0; y < 72; ++y) {
      for (int x = 0; x < 96; ++x) {
        for (int c = 0; c < 3; ++c) {
          const float v = std::min(1.0f, std::max(0.0f, ref.color.at(x, y, c)));
          ASSERT_NEAR(color.at<cv::Vec3b>(y, x)[2 - c], v * 255.0f, 0.5001f) << x << "," << y;
        }
        const float a = ref.alpha.at(x, y);
        const double expected = a > 0.5f ? std::round(ref.depth.at(x, y) / a * 5000.0) : 0.0;
        ASSERT_EQ(depth.at<uint16_t>(y, x), std::min(65535.0, expected)) << x << "," << y;
        opaque += a > 0.5f;
      }
    }
    EXPECT_GT(opaque, 1000);
  }
  const Trajectory back = ReadTumTrajectory(dir + "/poses.txt");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_NEAR(back.timestamps[1], 0.5, 1e-9);
  EXPECT_NEAR((back.world_from_cam[1].translation - path.world_from_cam[1].translation).norm(), 0, 1e-8);
}

TEST(RenderOffline, BadInputsAreClearErrors) {
  const GaussianCloud cloud = MakeDemoScene();
  const Camera camera = DemoCamera(32, 24);
  OfflineRenderOptions options;
  const std::string dir = testing::TestTempDir();
  EXPECT_INVALID_INPUT(RenderPath(camera, Trajectory{}, dir, options, CpuViewRenderer(cloud)), "no poses");
  Trajectory path;
  path.Add(0.0, Rigid3d());
  Camera bad = camera;
  bad.height = 0;
  EXPECT_INVALID_INPUT(RenderPath(bad, path, dir, options, CpuViewRenderer(cloud)), "height");
  options.settings.sh_degree = 7;
  EXPECT_INVALID_INPUT(RenderPath(camera, path, dir, options, CpuViewRenderer(cloud)), "sh_degree");
  // An empty map renders the background (documented), not an error.
  options.settings.sh_degree = 3;
  const GaussianCloud empty;
  EXPECT_EQ(RenderPath(camera, path, dir + "/empty", options, CpuViewRenderer(empty)).frames, 1);
  const cv::Mat d = cv::imread(dir + "/empty/depth_000000.png", cv::IMREAD_UNCHANGED);
  EXPECT_EQ(cv::countNonZero(d), 0);
}

#if defined(DYPHO_WITH_VULKAN)
// The Vulkan backend writes the same frames (8-bit colour within 2 levels on
// 99.9% of pixels; identical depth within 1% where both are opaque).
TEST(RenderOffline, VulkanBackendWritesTheSameFrames) {
  std::string why;
  if (!vulkan::VulkanAvailable(&why)) {
    if (testing::InCi()) FAIL() << why;
    GTEST_SKIP() << why;
  }
  const GaussianCloud cloud = MakeDemoScene();
  const Camera camera = DemoCamera(128, 96);
  OrbitOptions orbit;
  orbit.frames = 3;
  const Trajectory path = OrbitPath(cloud, orbit);
  OfflineRenderOptions options;
  const std::string dir = testing::TestTempDir();
  RenderPath(camera, path, dir + "/cpu", options, CpuViewRenderer(cloud));
  vulkan::VulkanRendererOptions vo;
  vo.validation = true;
  auto gpu = std::make_shared<vulkan::VulkanRenderer>(vo);
  gpu->SetMap(cloud);
  RenderPath(
      camera, path, dir + "/vk", options,
      [gpu](const Camera& c, const Rigid3d& p, const kernels::RasterSettings& s) { return gpu->Render(c, p, s); });
  EXPECT_EQ(gpu->validation_messages(), 0);
  for (int f = 0; f < 3; ++f) {
    char name[64];
    std::snprintf(name, sizeof(name), "/color_%06d.png", f);
    const cv::Mat a = cv::imread(dir + "/cpu" + name), b = cv::imread(dir + "/vk" + name);
    ASSERT_FALSE(a.empty());
    ASSERT_FALSE(b.empty());
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    cv::Mat big = diff.reshape(1) > 2;
    EXPECT_LE(cv::countNonZero(big), 0.001 * diff.total() * 3) << name;
    std::snprintf(name, sizeof(name), "/depth_%06d.png", f);
    const cv::Mat da = cv::imread(dir + "/cpu" + name, cv::IMREAD_UNCHANGED);
    const cv::Mat db = cv::imread(dir + "/vk" + name, cv::IMREAD_UNCHANGED);
    int compared = 0, within = 0;
    for (int y = 0; y < da.rows; ++y) {
      for (int x = 0; x < da.cols; ++x) {
        const int u = da.at<uint16_t>(y, x), v = db.at<uint16_t>(y, x);
        if (u == 0 || v == 0) continue;
        ++compared;
        within += std::abs(u - v) <= 0.01 * u;
      }
    }
    EXPECT_GT(compared, 1000);
    EXPECT_GE(within, 0.999 * compared) << name;
  }
}

// Without a Vulkan driver (the loader pointed at a missing ICD) the tools
// fail with the package to install, write nothing, and the CPU backend
// still works.
TEST(RenderOffline, NoVulkanDriverIsAClearError) {
  const std::string dir = testing::TestTempDir();
  SavePly(MakeDemoScene(), dir + "/map.ply");
  const std::string dypho = std::string(DYPHO_BINARY_DIR) + "/tools/dypho";
  const std::string args = " --map " + dir + "/map.ply --orbit --orbit-frames 2 --intrinsics 64,64,31.5,23.5,64,48";
  const std::string cmd = "VK_ICD_FILENAMES=" + dir + "/missing_icd.json " + dypho + " render" + args +
                          " --backend vulkan --out " + dir + "/vk > " + dir + "/log.txt 2>&1";
  EXPECT_NE(std::system(cmd.c_str()), 0);
  std::ifstream log(dir + "/log.txt");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("no Vulkan driver found"), std::string::npos) << text;
  EXPECT_NE(text.find("mesa-vulkan-drivers"), std::string::npos) << text;
  EXPECT_FALSE(std::filesystem::exists(dir + "/vk/color_000000.png"));
  const std::string cpu = "VK_ICD_FILENAMES=" + dir + "/missing_icd.json " + dypho + " render" + args +
                          " --backend cpu --out " + dir + "/cpu > " + dir + "/cpu_log.txt 2>&1";
  EXPECT_EQ(std::system(cpu.c_str()), 0);
  EXPECT_TRUE(std::filesystem::exists(dir + "/cpu/color_000001.png"));
}
#endif

}  // namespace
}  // namespace dypho
