// `dypho view`: an interactive window (GLFW + Vulkan swapchain) showing a
// Gaussian map rendered by the Vulkan splat renderer, with the trajectory
// and keyframe frusta drawn over it.
//
// Controls:
//   left drag: orbit around the target   right drag: pan   wheel: zoom
//   Tab: orbit <-> fly camera (fly: W/A/S/D move, Q/E down/up, left drag looks,
//        Shift = 5x faster)
//   M: sorted <-> order-independent compositing
//   P: ellipses <-> points (fixed-size discs)
//   T: trajectory and frusta on/off
//   C: save a screenshot (screenshot_NNNN.png in the current folder)
//   R: reset the view          Esc: quit
// The starting view is the first pose of `dypho render --orbit` with the
// same intrinsics and orbit defaults (or `start_pose`), so a screenshot
// taken before any input equals an offscreen render of that pose.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/rigid3.h"
#include "engine/eval/trajectory.h"
#include "engine/gaussians.h"
#include "kernels/rasterizer.h"

namespace dypho::vulkan {

struct ViewerOptions {
  Camera camera;                      // window size [px] and intrinsics; invalid = 1280x720, 60 deg
  std::optional<Rigid3d> start_pose;  // world_from_cam; default: orbit pose 0 of the map
  Trajectory trajectory;              // drawn as a yellow polyline (may be empty)
  std::vector<Rigid3d> keyframes;     // world_from_cam, drawn as cyan frusta
  kernels::RasterSettings settings;   // mode, SH degree, background
  bool points = false;                // start in point mode
  float point_radius = 1.5f;          // [px] in point mode
  double frustum_size = 0.0;          // [m] frustum depth; 0 = 5% of the orbit radius
  std::string screenshot;             // save the frame `frames` (or the first) here
  int frames = 0;                     // > 0: stop after this many frames
  bool validation = false;            // Khronos validation layer
};

// Opens the window and runs until closed (or `frames` frames). Returns 0,
// or 1 when the validation layer reported problems. Throws VulkanError
// when there is no display, no Vulkan driver or no presentable device
// (the message says what to install), InvalidInput for bad options.
int RunViewer(const GaussianCloud& cloud, const ViewerOptions& options);

}  // namespace dypho::vulkan
