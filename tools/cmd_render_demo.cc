// dypho render-demo: renders the built-in demo scene to PNG in both
// compositing modes (no data needed).
#include <chrono>
#include <cstdio>

#include <CLI/CLI.hpp>

#include "common/files.h"
#include "common/logging.h"
#include "engine/export/ply.h"
#include "engine/io/image_io.h"
#include "engine/render/demo_scene.h"
#include "engine/render/render.h"
#include "tools/command.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

// Depth as a false-colour PNG: near = bright.
ImageU8 DepthPreview(const ImageF& depth) {
  float lo = 1e30f, hi = 0;
  for (float d : depth.pixels()) {
    if (d > 0) {
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
  }
  ImageU8 out(depth.width(), depth.height(), 3, 0);
  for (int y = 0; y < depth.height(); ++y) {
    for (int x = 0; x < depth.width(); ++x) {
      const float d = depth.at(x, y);
      if (!(d > 0) || hi <= lo) continue;
      const float t = 1.0f - (d - lo) / (hi - lo);
      out.at(x, y, 0) = static_cast<uint8_t>(255 * std::min(1.0f, 2 * t));
      out.at(x, y, 1) = static_cast<uint8_t>(255 * t * t);
      out.at(x, y, 2) = static_cast<uint8_t>(255 * std::max(0.0f, 1 - 2 * t) * 0.8f);
    }
  }
  return out;
}

int RunRenderDemo(int argc, char** argv) {
  CLI::App app{"Render the built-in demo scene to PNG in both compositing modes."};
  std::string out_dir = "demo", ply_path;
  int width = 640, height = 480, threads = 0, sh_degree = 3;
  double angle = 0.0;
  app.add_option("--out", out_dir, "output folder")->capture_default_str()->check(NonEmptyPath());
  app.add_option("--width", width, "image width [px]")->capture_default_str()->check(CLI::Range(1, 16384));
  app.add_option("--height", height, "image height [px]")->capture_default_str()->check(CLI::Range(1, 16384));
  app.add_option("--angle", angle, "orbit angle of the camera [rad]")->capture_default_str();
  app.add_option("--sh-degree", sh_degree, "active SH degree")->capture_default_str()->check(CLI::Range(0, 3));
  app.add_option("--threads", threads, "CPU threads (0 = all cores, at most " + std::to_string(kMaxThreads) + ")")
      ->capture_default_str()
      ->check(CLI::Range(0, kMaxThreads));
  app.add_option("--save-ply", ply_path, "also save the demo scene as a 3DGS PLY map (for dypho render / view)")
      ->check(NonEmptyPath());
  CLI11_PARSE(app, argc, argv);

  MakeOutputDirectory(out_dir);
  const GaussianCloud cloud = MakeDemoScene();
  if (!ply_path.empty()) {
    SavePly(cloud, ply_path);
    std::printf("demo scene: %d Gaussians -> %s\n", cloud.size(), ply_path.c_str());
  }
  const Camera camera = DemoCamera(width, height);
  const Rigid3d cam_from_world = DemoCamFromWorld(angle);
  kernels::RasterSettings settings;
  settings.num_threads = threads;
  settings.sh_degree = sh_degree;
  settings.background[0] = settings.background[1] = settings.background[2] = 0.05f;
  auto rasterizer = kernels::CreateRasterizer(kernels::Backend::kCpu);
  for (auto mode : {kernels::CompositeMode::kSorted, kernels::CompositeMode::kOrderIndependent}) {
    settings.mode = mode;
    const auto t0 = std::chrono::steady_clock::now();
    const RenderedView view = RenderView(cloud, camera, cam_from_world, settings, rasterizer.get());
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const std::string name = mode == kernels::CompositeMode::kSorted ? "sorted" : "oit";
    WriteRgb8(JoinPath(out_dir, "demo_" + name + ".png"), ToRgb8(view.color));
    WriteRgb8(JoinPath(out_dir, "demo_" + name + "_depth.png"), DepthPreview(NormalizedDepth(view)));
    std::printf("%s: %d Gaussians (%d visible), %dx%d, %.1f ms -> %s/demo_%s.png\n",
                kernels::CompositeModeName(mode), cloud.size(), view.stats.num_visible, width, height, ms,
                out_dir.c_str(), name.c_str());
  }
  return 0;
}

}  // namespace

DYPHO_COMMAND("render-demo", "render the built-in demo scene to PNG (both compositing modes)", RunRenderDemo);

}  // namespace dypho::tools
