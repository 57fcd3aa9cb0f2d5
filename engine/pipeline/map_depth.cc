#include "engine/pipeline/map_depth.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <chrono>
#include <cmath>

#include "common/check.h"
#include "common/logging.h"
#include "common/thread_name.h"
#include "engine/api.h"
#include "engine/render/render.h"

namespace dypho {

cv::Mat WarpMapDepth(const cv::Mat& depth, const Camera& camera, const Rigid3d& target_from_source,
                     double max_depth) {
  DYPHO_CHECK_INPUT(depth.type() == CV_32FC1 && depth.cols == camera.width && depth.rows == camera.height)
      << "WarpMapDepth: depth must be CV_32FC1 of the camera's size " << camera.width << "x" << camera.height;
  const int w = camera.width, h = camera.height;
  cv::Mat warped(h, w, CV_32FC1, cv::Scalar(0.0f));
  const Eigen::Matrix3f r = target_from_source.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f t = target_from_source.translation.cast<float>();
  const float fx = static_cast<float>(camera.fx), fy = static_cast<float>(camera.fy);
  const float cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  const float zmax = static_cast<float>(max_depth);
  float* out = warped.ptr<float>();
  for (int v = 0; v < h; ++v) {
    const float* row = depth.ptr<float>(v);
    const float ry = (v - cy) / fy;
    for (int u = 0; u < w; ++u) {
      const float z = row[u];
      if (!(z > 0.0f && z <= zmax)) continue;
      const Eigen::Vector3f p = r * Eigen::Vector3f(z * (u - cx) / fx, z * ry, z) + t;
      if (!(p.z() > 1e-3f)) continue;
      const float pu = fx * p.x() / p.z() + cx, pv = fy * p.y() / p.z() + cy;
      if (!(pu >= -0.5f && pv >= -0.5f && pu < w - 0.5f && pv < h - 0.5f)) continue;
      float& o = out[static_cast<int>(pv + 0.5f) * w + static_cast<int>(pu + 0.5f)];
      if (o == 0.0f || p.z() < o) o = p.z();
    }
  }
  // Cracks: an empty pixel between two filled ones (left-right, up-down or
  // diagonally) gets the mean of its filled 8-neighbours.
  cv::Mat filled = warped.clone();
  for (int v = 1; v + 1 < h; ++v) {
    const float* up = warped.ptr<float>(v - 1);
    const float* row = warped.ptr<float>(v);
    const float* down = warped.ptr<float>(v + 1);
    float* o = filled.ptr<float>(v);
    for (int u = 1; u + 1 < w; ++u) {
      if (row[u] != 0.0f) continue;
      const bool between = (row[u - 1] != 0.0f && row[u + 1] != 0.0f) || (up[u] != 0.0f && down[u] != 0.0f) ||
                           (up[u - 1] != 0.0f && down[u + 1] != 0.0f) || (up[u + 1] != 0.0f && down[u - 1] != 0.0f);
      if (!between) continue;
      float sum = 0.0f;
      int n = 0;
      for (const float* p : {up + u - 1, up + u, up + u + 1, row + u - 1, row + u + 1, down + u - 1, down + u,
                             down + u + 1}) {
        if (*p != 0.0f) {
          sum += *p;
          ++n;
        }
      }
      o[u] = sum / n;
    }
  }
  return filled;
}

cv::Mat RenderMapDepth(const GaussianCloud& cloud, const Camera& camera, const Rigid3d& cam_from_world,
                       const kernels::RasterSettings& settings, float min_alpha) {
  const RenderedView view = RenderView(cloud, camera, cam_from_world, settings);
  const ImageF depth = NormalizedDepth(view, min_alpha);
  cv::Mat out(depth.height(), depth.width(), CV_32FC1);
  std::copy(depth.data(), depth.data() + depth.size(), out.ptr<float>());
  return out;
}

MapDepthRenderer::MapDepthRenderer(const Engine* engine, const Camera& camera, const kernels::RasterSettings& settings,
                                   bool threaded, int nice, int fixed_lag, double debug_delay_ms)
    : engine_(engine),
      camera_(camera),
      settings_(settings),
      threaded_(threaded),
      nice_(nice),
      fixed_lag_(threaded ? fixed_lag : 0),
      debug_delay_ms_(debug_delay_ms) {
  if (threaded_) thread_ = std::thread([this] { Loop(); });
}

MapDepthRenderer::~MapDepthRenderer() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void MapDepthRenderer::Request(const Rigid3d& cam_from_world, long frame) {
  if (!threaded_) {
    Render(cam_from_world, frame);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    request_ = std::make_pair(cam_from_world, frame);
    if (fixed_lag_ > 0) {
      in_flight_ = frame;
      answered_ = false;
      result_.reset();
    }
  }
  cv_.notify_all();
}

bool MapDepthRenderer::busy() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (fixed_lag_ > 0) return in_flight_ >= 0;
  return request_.has_value() || rendering_;
}

std::optional<MapDepth> MapDepthRenderer::TakeDue(long frame, double* wait_ms) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (fixed_lag_ <= 0 || in_flight_ < 0 || frame - in_flight_ < fixed_lag_) return std::nullopt;
  if (!answered_) {
    const auto start = std::chrono::steady_clock::now();
    cv_.wait(lock, [&] { return answered_; });
    if (wait_ms) *wait_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  in_flight_ = -1;
  std::optional<MapDepth> out = std::move(result_);
  result_.reset();
  return out;
}

std::optional<MapDepth> MapDepthRenderer::Take() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<MapDepth> out = std::move(result_);
  result_.reset();
  return out;
}

int MapDepthRenderer::renders() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return renders_;
}

void MapDepthRenderer::Loop() {
  SetCurrentThreadName("dypho-mapdepth");
  if (nice_ > 0) {
    // Linux: the nice value is per thread (the thread id as the "process").
    const pid_t tid = static_cast<pid_t>(syscall(SYS_gettid));
    if (setpriority(PRIO_PROCESS, static_cast<id_t>(tid), nice_) != 0) {
      DYPHO_LOG(Warning) << "map depth renderer: could not lower its priority (nice " << nice_ << ")";
    }
  }
  for (;;) {
    std::pair<Rigid3d, long> request;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return stop_ || request_.has_value(); });
      if (stop_) return;
      request = *request_;
      request_.reset();
      rendering_ = true;
    }
    if (debug_delay_ms_ > 0)
      std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(debug_delay_ms_));
    Render(request.first, request.second);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      rendering_ = false;
      answered_ = true;
    }
    cv_.notify_all();
  }
}

void MapDepthRenderer::Render(const Rigid3d& cam_from_world, long frame) {
  const auto start = std::chrono::steady_clock::now();
  // A new snapshot when keyframes were mapped since the last one (Map()
  // waits for the mapper's current optimisation step: on this thread, not
  // the tracking thread's).
  const int mapped = engine_->QueueStatus().mapped_keyframes;
  if (mapped == 0) return;
  if (mapped != snapshot_keyframes_) {
    snapshot_ = engine_->Map();
    snapshot_keyframes_ = mapped;
  }
  if (snapshot_.empty()) return;
  MapDepth result;
  result.depth = RenderMapDepth(snapshot_, camera_, cam_from_world, settings_);
  result.cam_from_world = cam_from_world;
  result.frame = frame;
  result.mapped_keyframes = snapshot_keyframes_;
  result.render_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::lock_guard<std::mutex> lock(mutex_);
  result_ = std::move(result);
  ++renders_;
}

}  // namespace dypho
