// dypho view: interactive viewer of a map (3DGS PLY) with the Vulkan
// renderer (GLFW window), the trajectory and keyframe frusta drawn over it.
#include <cstdio>
#include <sstream>

#include <CLI/CLI.hpp>

#include "common/check.h"
#include "engine/eval/trajectory.h"
#include "engine/export/export.h"
#include "engine/render/offline_render.h"
#if defined(DYPHO_WITH_VULKAN)
#include "engine/vulkan/viewer.h"
#endif
#include "tools/command.h"

namespace dypho::tools {
namespace {

int RunView(int argc, char** argv) {
  CLI::App app{"Look at a map interactively (Vulkan window). Keys: see engine/vulkan/viewer.h or the printed help."};
  std::string map_path, trajectory_path, keyframes_path, intrinsics, mode = "sorted", screenshot, start_pose;
  int frames = 0, sh_degree = 3;
  bool exit_after = false, points = false, validation = false;
  std::vector<float> background{0, 0, 0};
  app.add_option("map", map_path, "Gaussian map: .ply (3DGS), .splat, .glb or .gltf")->required()->check(CLI::ExistingFile);
  app.add_option("--trajectory", trajectory_path, "camera trajectory to draw (TUM format)")->check(CLI::ExistingFile);
  app.add_option("--keyframes", keyframes_path, "keyframe poses to draw as frusta (TUM format)")
      ->check(CLI::ExistingFile);
  app.add_option("--intrinsics", intrinsics,
                 "window size and intrinsics: camera file or \"fx,fy,cx,cy,width,height\" (default 1280x720, 60 deg)");
  app.add_option("--start-pose", start_pose,
                 "starting camera pose \"tx,ty,tz,qx,qy,qz,qw\" (world_from_cam, TUM order; default: orbit view)");
  app.add_option("--mode", mode, "start in sorted or oit compositing")
      ->capture_default_str()
      ->check(CLI::IsMember({"sorted", "oit"}));
  app.add_flag("--points", points, "start with points instead of ellipses");
  app.add_option("--sh-degree", sh_degree, "active SH degree")->capture_default_str()->check(CLI::Range(0, 3));
  app.add_option("--background", background, "background colour r g b in [0, 1]")->expected(3);
  app.add_option("--screenshot", screenshot, "save the last frame (of --frames) as PNG");
  app.add_option("--frames", frames, "render this many frames, then stop (0 = until closed)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--exit", exit_after, "with --screenshot: exit after saving it (same as --frames 1 by default)");
  app.add_flag("--validation", validation, "enable the Khronos validation layer");
  CLI11_PARSE(app, argc, argv);

#if defined(DYPHO_WITH_VULKAN)
  vulkan::ViewerOptions options;
  if (!intrinsics.empty()) options.camera = ParseIntrinsics(intrinsics);
  if (!trajectory_path.empty()) options.trajectory = ReadTumTrajectory(trajectory_path);
  if (!keyframes_path.empty()) options.keyframes = ReadTumTrajectory(keyframes_path).world_from_cam;
  if (!start_pose.empty()) {
    std::vector<double> v;
    std::stringstream text(start_pose);
    std::string item;
    while (std::getline(text, item, ',')) {
      try {
        v.push_back(std::stod(item));
      } catch (const std::exception&) {
        DYPHO_CHECK_INPUT(false) << "--start-pose: \"" << item << "\" is not a number";
      }
    }
    DYPHO_CHECK_INPUT(v.size() == 7) << "--start-pose expects tx,ty,tz,qx,qy,qz,qw (got " << v.size() << " values)";
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    DYPHO_CHECK_INPUT(q.norm() > 1e-9) << "--start-pose: zero quaternion";
    options.start_pose = Rigid3d(q, Eigen::Vector3d(v[0], v[1], v[2]));
  }
  options.settings.mode = mode == "oit" ? kernels::CompositeMode::kOrderIndependent : kernels::CompositeMode::kSorted;
  options.settings.sh_degree = sh_degree;
  for (int c = 0; c < 3; ++c) options.settings.background[c] = background[c];
  options.points = points;
  options.screenshot = screenshot;
  options.frames = frames;
  if (exit_after && frames == 0) options.frames = 1;
  DYPHO_CHECK_INPUT(!exit_after || !screenshot.empty() || frames > 0) << "--exit needs --screenshot or --frames";
  options.validation = validation;
  const GaussianCloud cloud = LoadMap(map_path);
  return vulkan::RunViewer(cloud, options);
#else
  DYPHO_CHECK_INPUT(false) << "this dypho was built without the Vulkan viewer: install libvulkan-dev, glslc and "
                              "libglfw3-dev (tools/install.sh) and rebuild";
  return 1;
#endif
}

}  // namespace

DYPHO_COMMAND("view", "interactive Vulkan viewer of a map with trajectory and keyframe frusta", RunView);

}  // namespace dypho::tools
