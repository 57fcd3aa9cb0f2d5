// The map's depth for the background model (`dypho run`, step 3): renders
// of the map at a requested pose, made on a helper thread so that the
// tracking thread never waits for the mapper's lock or for the rasterizer,
// and forward-warped to the pose the tracking thread needs.
//
// Rendering 10^5 Gaussians costs about as much at 160x120 as at 640x480 (the
// projection of every Gaussian dominates), tens to hundreds of ms on a
// shared core; the background model only needs the map's depth now and then
// because it carries its background from frame to frame itself
// (masking/background_model.h). So the tracking thread asks for a render at
// its predicted pose every few frames (MapDepthRenderer::Request); when the
// render arrives some frames later, WarpMapDepth moves it to the current
// predicted pose: every valid pixel is unprojected with its depth, moved by
// target_from_source, projected and z-buffered (the nearest surface wins),
// one-pixel cracks are filled from their neighbours. Pixels the source did
// not see stay empty (0) and the background model falls back to its own
// warped background there.
//
// With `threaded` false, Request renders at once on the caller's thread
// (deterministic, for the sequential mode).
//
// Fixed lag (threaded, fixed_lag = n > 0): a request made at frame k is
// answered at frame k + n exactly (TakeDue waits for the render when it is
// late; an early render waits unused), and a new request is accepted only
// when none is in flight, so which renders reach which frames does not
// depend on timing. (What the map holds when the helper snapshots it still
// depends on the mapping thread's progress.)
#pragma once

#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/rigid3.h"
#include "engine/gaussians.h"
#include "kernels/rasterizer.h"

namespace dypho {

class Engine;

// `depth` (CV_32FC1 [m] of `camera`'s size, 0 = none) seen from a pinhole
// camera with the same intrinsics at target_from_source (x_target =
// target_from_source * x_source): z-buffered forward warp plus one-pixel
// crack filling; depths beyond max_depth or <= 0 are ignored.
cv::Mat WarpMapDepth(const cv::Mat& depth, const Camera& camera, const Rigid3d& target_from_source,
                     double max_depth = 20.0);

// The depth of a render: camera z where the accumulated opacity exceeds
// min_alpha, else 0. CV_32FC1 of `camera`'s size.
cv::Mat RenderMapDepth(const GaussianCloud& cloud, const Camera& camera, const Rigid3d& cam_from_world,
                       const kernels::RasterSettings& settings, float min_alpha = 0.5f);

struct MapDepth {
  cv::Mat depth;            // CV_32FC1 [m] at the render camera's size, 0 = nothing rendered
  Rigid3d cam_from_world;   // the pose it was rendered at
  long frame = -1;          // the frame that asked for it
  int mapped_keyframes = 0; // keyframes in the map it was rendered from
  double render_ms = 0.0;   // snapshot and render time on the thread that made it
};

class MapDepthRenderer {
 public:
  // `camera`: the (pinhole) render camera; `settings`: rasterizer settings
  // (num_threads: the helper's threads). `nice` > 0 lowers the helper
  // thread's scheduling priority (Linux nice value) so that it takes idle
  // time rather than the tracking thread's.
  // `fixed_lag`: see above (0 = a render is taken whenever it has
  // arrived); `debug_delay_ms`: test hook, the helper sleeps this long
  // before each render [ms].
  MapDepthRenderer(const Engine* engine, const Camera& camera, const kernels::RasterSettings& settings,
                   bool threaded, int nice = 0, int fixed_lag = 0, double debug_delay_ms = 0.0);
  ~MapDepthRenderer();
  MapDepthRenderer(const MapDepthRenderer&) = delete;
  MapDepthRenderer& operator=(const MapDepthRenderer&) = delete;

  // Asks for a render at `cam_from_world` for frame `frame`. Threaded: a
  // request still waiting is replaced (the newest pose wins); returns at
  // once. Otherwise renders now. Nothing is rendered while the map is empty.
  void Request(const Rigid3d& cam_from_world, long frame);
  // True while a request is waiting or being rendered (fixed lag: while a
  // request has not been answered by TakeDue).
  bool busy() const;
  // Fixed lag: at frame `frame`, the answer to the request in flight when
  // its frame + fixed_lag has come (waiting for the helper; nullopt when
  // nothing was rendered: an empty map), else nullopt. Adds the time spent
  // waiting to *wait_ms.
  std::optional<MapDepth> TakeDue(long frame, double* wait_ms);
  // The newest finished render not taken yet.
  std::optional<MapDepth> Take();
  // Renders made so far.
  int renders() const;

 private:
  void Loop();
  void Render(const Rigid3d& cam_from_world, long frame);

  const Engine* engine_;
  const Camera camera_;
  const kernels::RasterSettings settings_;
  const bool threaded_;
  const int nice_;
  const int fixed_lag_;
  const double debug_delay_ms_;
  long in_flight_ = -1;  // fixed lag: the frame of the request not answered yet (-1 = none)
  bool answered_ = false;  // fixed lag: the helper is done with the request in flight
  GaussianCloud snapshot_;    // the helper's copy of the map
  int snapshot_keyframes_ = 0;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<std::pair<Rigid3d, long>> request_;
  bool rendering_ = false;
  bool stop_ = false;
  std::optional<MapDepth> result_;
  int renders_ = 0;
  std::thread thread_;
};

}  // namespace dypho
