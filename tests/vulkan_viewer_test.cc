// `dypho view` under a virtual X server (xvfb-run, Debian package xvfb) with
// lavapipe: the screenshot of the presented swapchain image equals an
// offscreen Vulkan render of the same view (8-bit values within 1 on 99.9%
// of pixels) and is close to the CPU reference (PSNR >= 35 dB); the
// trajectory and frusta overlay draws its colours; the validation layer
// (when installed) stays silent (the program exits 1 otherwise).
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "engine/export/ply.h"
#include "engine/io/image_io.h"
#include "engine/render/demo_scene.h"
#include "engine/render/offline_render.h"
#include "engine/vulkan/vulkan_renderer.h"
#include "tests/test_data.h"
#include "tests/vulkan_test_scenes.h"

namespace dypho {
namespace {

const char* kIntrinsics = "200,200,79.5,59.5,160,120";

class VulkanViewer : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (!vulkan::VulkanAvailable(&why)) {
      if (testing::InCi()) FAIL() << why;
      GTEST_SKIP() << why;
    }
    if (std::system("command -v xvfb-run > /dev/null 2>&1") == 0) {
      prefix_ = "xvfb-run -a ";
    } else if (std::getenv("DISPLAY") == nullptr) {
      if (testing::InCi()) FAIL() << "xvfb-run is missing (Debian package xvfb)";
      GTEST_SKIP() << "no display and no xvfb-run (install the Debian package xvfb)";
    }
    dir_ = testing::TestTempDir();
    cloud_ = MakeDemoScene();
    SavePly(cloud_, dir_ + "/map.ply");
    camera_ = ParseIntrinsics(kIntrinsics);
  }

  // Runs dypho view and returns its screenshot.
  ImageU8 Screenshot(const std::string& extra) {
    const std::string shot = dir_ + "/shot.png";
    std::filesystem::remove(shot);
    const std::string cmd = prefix_ + std::string(DYPHO_BINARY_DIR) + "/tools/dypho view " + dir_ +
                            "/map.ply --intrinsics " + kIntrinsics + " --screenshot " + shot +
                            " --frames 3 --exit --validation " + extra + " > " + dir_ + "/log.txt 2>&1";
    const int rc = std::system(cmd.c_str());
    std::ifstream log(dir_ + "/log.txt");
    const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    EXPECT_EQ(rc, 0) << cmd << "\n" << text;
    EXPECT_TRUE(std::filesystem::exists(shot)) << text;
    return std::filesystem::exists(shot) ? ReadRgb8(shot) : ImageU8();
  }

  // Offscreen render of the viewer's start view: pose 0 of the orbit.
  RenderedView Offscreen(kernels::CompositeMode mode, bool cpu) {
    const Rigid3d world_from_cam = OrbitPath(cloud_, OrbitOptions{}).world_from_cam[0];
    kernels::RasterSettings settings;
    settings.mode = mode;
    if (cpu) return RenderView(cloud_, camera_, world_from_cam.Inverse(), settings);
    vulkan::VulkanRenderer renderer;
    renderer.SetMap(cloud_);
    return renderer.Render(camera_, world_from_cam.Inverse(), settings);
  }

  std::string prefix_, dir_;
  GaussianCloud cloud_;
  Camera camera_;
};

int PixelsDifferingBy(const ImageU8& a, const ImageU8& b, int more_than) {
  int n = 0;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      bool differs = false;
      for (int c = 0; c < 3; ++c) differs |= std::abs(int(a.at(x, y, c)) - int(b.at(x, y, c))) > more_than;
      n += differs;
    }
  }
  return n;
}

TEST_F(VulkanViewer, ScreenshotMatchesOffscreenRenderBothModes) {
  for (auto mode : {kernels::CompositeMode::kSorted, kernels::CompositeMode::kOrderIndependent}) {
    const bool oit = mode == kernels::CompositeMode::kOrderIndependent;
    const ImageU8 shot = Screenshot(oit ? "--mode oit" : "");
    ASSERT_EQ(shot.width(), 160);
    ASSERT_EQ(shot.height(), 120);
    const ImageU8 offscreen = ToRgb8(Offscreen(mode, false).color);
    EXPECT_LE(PixelsDifferingBy(shot, offscreen, 1), 0.001 * 160 * 120) << kernels::CompositeModeName(mode);
    // And the CPU reference of the same view.
    EXPECT_GE(testing::Psnr(ToFloat(shot), ToFloat(ToRgb8(Offscreen(mode, true).color))), 35.0);
  }
}

TEST_F(VulkanViewer, StartPoseFlagSetsTheView) {
  // An orbit pose other than the default start view, given as TUM numbers.
  OrbitOptions orbit;
  orbit.frames = 5;
  const Rigid3d pose = OrbitPath(cloud_, orbit).world_from_cam[2];
  const Eigen::Quaterniond& q = pose.rotation;
  char arg[256];
  std::snprintf(arg, sizeof(arg), "--start-pose %.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f", pose.translation.x(),
                pose.translation.y(), pose.translation.z(), q.x(), q.y(), q.z(), q.w());
  const ImageU8 shot = Screenshot(arg);
  ASSERT_EQ(shot.width(), 160);
  vulkan::VulkanRenderer renderer;
  renderer.SetMap(cloud_);
  const ImageU8 offscreen = ToRgb8(renderer.Render(camera_, pose.Inverse(), kernels::RasterSettings{}).color);
  EXPECT_LE(PixelsDifferingBy(shot, offscreen, 1), 0.001 * 160 * 120);
  const ImageU8 start = ToRgb8(Offscreen(kernels::CompositeMode::kSorted, false).color);
  EXPECT_GT(PixelsDifferingBy(shot, start, 8), 1000);  // not the default view
}

TEST_F(VulkanViewer, OverlayDrawsTrajectoryAndFrusta) {
  // A trajectory crossing the view in front of the map and keyframes on it.
  const Rigid3d world_from_cam = OrbitPath(cloud_, OrbitOptions{}).world_from_cam[0];
  const Eigen::Vector3d centre = MapCentre(cloud_);
  const Eigen::Vector3d right = world_from_cam.rotation * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d toward = world_from_cam.translation - centre;
  Trajectory path;
  for (int i = 0; i < 5; ++i) {
    const Eigen::Vector3d p = centre + 0.5 * toward + (i - 2) * 0.15 * toward.norm() * right;
    path.Add(i, Rigid3d(world_from_cam.rotation, p));
  }
  WriteTumTrajectory(dir_ + "/path.txt", path);
  const ImageU8 plain = Screenshot("");
  const ImageU8 lines = Screenshot("--trajectory " + dir_ + "/path.txt --keyframes " + dir_ + "/path.txt");
  int yellow = 0, cyan = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const int r = lines.at(x, y, 0), g = lines.at(x, y, 1), b = lines.at(x, y, 2);
      yellow += r == 255 && g == 217 && b == 26;  // (1.0, 0.85, 0.1)
      cyan += r == 51 && g == 230 && b == 255;    // (0.2, 0.9, 1.0)
    }
  }
  EXPECT_GT(yellow, 20);
  EXPECT_GT(cyan, 20);
  // Away from the lines the image is unchanged.
  EXPECT_LE(PixelsDifferingBy(plain, lines, 0), yellow + cyan + 200);
}

TEST_F(VulkanViewer, PointModeRendersAndBadMapIsAClearError) {
  const ImageU8 points = Screenshot("--points");
  ASSERT_EQ(points.width(), 160);
  const ImageU8 ellipses = Screenshot("");
  EXPECT_GT(PixelsDifferingBy(points, ellipses, 8), 100);  // a different look, still an image
  std::ofstream(dir_ + "/bad.ply") << "not a ply\n";
  const std::string cmd = prefix_ + std::string(DYPHO_BINARY_DIR) + "/tools/dypho view " + dir_ +
                          "/bad.ply --frames 1 --exit > " + dir_ + "/bad.txt 2>&1";
  EXPECT_NE(std::system(cmd.c_str()), 0);
  std::ifstream log(dir_ + "/bad.txt");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("bad.ply"), std::string::npos) << text;
}

}  // namespace
}  // namespace dypho
