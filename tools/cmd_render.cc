// dypho render: novel views of a finished map (3DGS PLY) along a TUM
// trajectory or an orbit, with the CPU rasterizer or the Vulkan renderer.
#include <cstdio>
#include <memory>
#include <sstream>

#include <CLI/CLI.hpp>

#include "common/check.h"
#include "common/files.h"
#include "engine/export/export.h"
#include "engine/render/offline_render.h"
#if defined(DYPHO_WITH_VULKAN)
#include "engine/vulkan/vulkan_renderer.h"
#endif
#include "tools/command.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

Eigen::Vector3d ParseVector(const std::string& text, const char* flag) {
  std::stringstream s(text);
  std::string item;
  std::vector<double> v;
  while (std::getline(s, item, ',')) {
    try {
      v.push_back(std::stod(item));
    } catch (const std::exception&) {
      DYPHO_CHECK_INPUT(false) << flag << ": \"" << item << "\" is not a number";
    }
  }
  DYPHO_CHECK_INPUT(v.size() == 3) << flag << " expects x,y,z (got \"" << text << "\")";
  return {v[0], v[1], v[2]};
}

int RunRender(int argc, char** argv) {
  CLI::App app{"Render colour and 16-bit depth PNGs of a map along a trajectory or an orbit."};
  std::string map_path, trajectory_path, intrinsics, out_dir, mode = "sorted", backend = "cpu", up = "0,-1,0";
  bool orbit = false, validation = false;
  OrbitOptions orbit_options;
  OfflineRenderOptions options;
  std::vector<float> background{0, 0, 0};
  app.add_option("--map", map_path, "Gaussian map: .ply (3DGS), .splat, .glb or .gltf")->required()->check(CLI::ExistingFile);
  auto* traj = app.add_option("--trajectory", trajectory_path, "camera poses, TUM format (world_from_cam)")
                   ->check(CLI::ExistingFile);
  auto* orb = app.add_flag("--orbit", orbit, "orbit around the map's centre looking at it");
  traj->excludes(orb);
  app.add_option("--orbit-frames", orbit_options.frames, "views on the orbit")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  app.add_option("--orbit-radius", orbit_options.radius, "orbit radius [m]; 0 = 2 x the map's 80th-percentile extent")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--orbit-elevation", orbit_options.elevation, "camera height angle above the orbit plane [rad]")
      ->capture_default_str();
  app.add_option("--orbit-revolutions", orbit_options.revolutions, "turns")->capture_default_str();
  app.add_option("--orbit-up", up, "world up vector x,y,z")->capture_default_str();
  app.add_option("--intrinsics", intrinsics, "camera file (YAML/JSON) or \"fx,fy,cx,cy,width,height\"")->required();
  app.add_option("--mode", mode, "compositing: sorted or oit")
      ->capture_default_str()
      ->check(CLI::IsMember({"sorted", "oit"}));
  app.add_option("--backend", backend, "renderer: cpu or vulkan")
      ->capture_default_str()
      ->check(CLI::IsMember({"cpu", "vulkan"}));
  app.add_option("--sh-degree", options.settings.sh_degree, "active SH degree")
      ->capture_default_str()
      ->check(CLI::Range(0, 3));
  app.add_option("--threads", options.settings.num_threads,
                 "CPU threads (0 = all cores, at most " + std::to_string(kMaxThreads) + ")")
      ->capture_default_str()
      ->check(CLI::Range(0, kMaxThreads));
  app.add_option("--background", background, "background colour r g b in [0, 1]")->expected(3)->capture_default_str();
  app.add_option("--depth-factor", options.depth_factor, "depth PNG units per metre")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_flag("--validation", validation, "Vulkan: enable the Khronos validation layer");
  app.add_option("--out", out_dir, "output folder")->required()->check(NonEmptyPath());
  CLI11_PARSE(app, argc, argv);
  DYPHO_CHECK_INPUT(orbit || !trajectory_path.empty()) << "render: give --trajectory FILE or --orbit";

  options.settings.mode = mode == "oit" ? kernels::CompositeMode::kOrderIndependent : kernels::CompositeMode::kSorted;
  for (int c = 0; c < 3; ++c) options.settings.background[c] = background[c];
  const Camera camera = ParseIntrinsics(intrinsics);
  const GaussianCloud cloud = LoadMap(map_path);
  Trajectory path;
  if (orbit) {
    orbit_options.up = ParseVector(up, "--orbit-up");
    path = OrbitPath(cloud, orbit_options);
  } else {
    path = ReadTumTrajectory(trajectory_path);
  }

  ViewRenderFn render;
#if defined(DYPHO_WITH_VULKAN)
  std::shared_ptr<vulkan::VulkanRenderer> gpu;
#endif
  if (backend == "vulkan") {
#if defined(DYPHO_WITH_VULKAN)
    vulkan::VulkanRendererOptions vk;
    vk.validation = validation;
    gpu = std::make_shared<vulkan::VulkanRenderer>(vk);
    gpu->SetMap(cloud);
    render = [gpu](const Camera& c, const Rigid3d& pose, const kernels::RasterSettings& s) {
      return gpu->Render(c, pose, s);
    };
#else
    DYPHO_CHECK_INPUT(false) << "this dypho was built without the Vulkan renderer: install libvulkan-dev, glslc "
                                "and libglfw3-dev (tools/install.sh) and rebuild, or use --backend cpu";
#endif
  } else {
    render = CpuViewRenderer(cloud);
  }
  const OfflineRenderSummary summary = RenderPath(camera, path, out_dir, options, render);
  std::printf("rendered %d frames (%d Gaussians, %dx%d, %s, %s) in %.2f s -> %s\n", summary.frames, cloud.size(),
              camera.width, camera.height, mode.c_str(), backend.c_str(), summary.seconds, out_dir.c_str());
#if defined(DYPHO_WITH_VULKAN)
  if (gpu && gpu->validation_messages() > 0) {
    std::fprintf(stderr, "dypho render: the Vulkan validation layer reported %d problems\n",
                 gpu->validation_messages());
    return 1;
  }
#endif
  return 0;
}

}  // namespace

DYPHO_COMMAND("render", "render colour and depth PNGs of a map along a trajectory or an orbit (CPU or Vulkan)",
              RunRender);

}  // namespace dypho::tools
