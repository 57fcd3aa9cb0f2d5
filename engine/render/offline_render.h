// Offline rendering of a finished map along a camera path (`dypho render`):
// colour PNGs and 16-bit depth PNGs for every pose of a TUM trajectory or of
// an orbit around the map, with progress. The rendering itself is a
// callback so the same writer serves the CPU rasterizer and the Vulkan
// renderer (engine/vulkan; the engine does not depend on Vulkan).
//
// Output folder:
//   color_NNNNNN.png  8-bit RGB, linear colour clamped to [0, 1], rounded
//   depth_NNNNNN.png  16-bit, metres x depth_factor (default 5000, the TUM
//                     convention), depth / alpha where alpha > min_alpha
//                     (0.5), else 0; beyond 65535 / factor (13.1 m at 5000)
//                     saturates at 65535
//   poses.txt         the poses used, TUM format (world_from_cam), one line
//                     per frame, frame k = line k
// Every file is written atomically (temporary name, then rename).
#pragma once

#include <functional>
#include <string>

#include <Eigen/Core>

#include "common/camera.h"
#include "common/rigid3.h"
#include "engine/eval/trajectory.h"
#include "engine/gaussians.h"
#include "engine/render/render.h"
#include "kernels/rasterizer.h"

namespace dypho {

// Renders one view of the map (the map is bound by whoever made the function).
using ViewRenderFn =
    std::function<RenderedView(const Camera& camera, const Rigid3d& cam_from_world, const kernels::RasterSettings&)>;

// The CPU reference rasterizer rendering `cloud` (kept by reference).
ViewRenderFn CpuViewRenderer(const GaussianCloud& cloud);

// Intrinsics from a camera file (YAML/JSON, engine/dataset/camera_file.h) or
// the text "fx,fy,cx,cy,width,height". Throws InvalidInput naming the text
// or file. Distortion is ignored by the renderers.
Camera ParseIntrinsics(const std::string& text_or_path);

struct OrbitOptions {
  int frames = 60;               // views, evenly spaced over the revolutions
  double radius = 0.0;           // [m] camera distance from the centre; 0 = automatic (below)
  double elevation = 0.35;       // [rad] camera height angle above the orbit plane
  double revolutions = 1.0;      // turns around the centre
  Eigen::Vector3d up{0, -1, 0};  // world up (maps in camera-like frames have y down)
  double timestep = 1.0 / 30;    // [s] between poses in poses.txt
};

// The map's centre for orbits: per-axis median of the finite means. Throws
// InvalidInput when no mean is finite (e.g. an empty map).
Eigen::Vector3d MapCentre(const GaussianCloud& cloud);
// 2 x the 80th percentile of the finite means' distances to `centre`, at
// least 0.1 m.
double AutoOrbitRadius(const GaussianCloud& cloud, const Eigen::Vector3d& centre);
// The orbit pose (world_from_cam) at angle `theta` [rad]: position
// centre + radius (cos(elevation) (cos(theta) a + sin(theta) b) + sin(elevation) up)
// with a = up.unitOrthogonal(), b = up x a, looking at the centre.
Rigid3d OrbitPose(const Eigen::Vector3d& centre, double radius, double theta, double elevation,
                  const Eigen::Vector3d& up);

// Poses (world_from_cam) on a circle around the map's centre (per-axis
// median of the means), each looking at the centre with image y along -up.
// Automatic radius: 2 x the 80th percentile of the means' distances to the
// centre (at least 0.1 m). Throws InvalidInput for an empty map with
// automatic centre/radius, frames < 1, radius < 0 or a zero up vector.
Trajectory OrbitPath(const GaussianCloud& cloud, const OrbitOptions& options);

// The camera pose at `position` looking at `target` with image y along -up.
Rigid3d LookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target, const Eigen::Vector3d& up);

struct OfflineRenderOptions {
  kernels::RasterSettings settings;  // mode, SH degree, background, threads
  double depth_factor = 5000.0;      // depth PNG units per metre
  float min_alpha = 0.5f;            // depth is 0 where alpha <= this
};

struct OfflineRenderSummary {
  int frames = 0;
  double seconds = 0.0;  // wall time of rendering and writing
};

// Renders every pose of `path` with `render` and writes the folder above
// (created if needed). Logs progress (frames, rate, time left). Throws
// InvalidInput for an empty path, a bad camera or settings, or unwritable
// output.
OfflineRenderSummary RenderPath(const Camera& camera, const Trajectory& path, const std::string& out_dir,
                                const OfflineRenderOptions& options, const ViewRenderFn& render);

}  // namespace dypho
