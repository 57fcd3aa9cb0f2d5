#include "engine/dense/dense_mapper.h"

#include <chrono>

#include "common/check.h"
#include "common/logging.h"
#include "common/thread_name.h"

namespace dypho {
namespace {

bool FinitePose(const Rigid3d& p) { return p.translation.allFinite() && p.rotation.coeffs().allFinite(); }

}  // namespace

void DenseMapOptions::Validate() const {
  std::string error;
  DYPHO_CHECK_INPUT(points.IsValid(&error)) << "dense.points: " << error;
  DYPHO_CHECK_INPUT(map.IsValid(&error)) << "dense.map: " << error;
  DYPHO_CHECK_INPUT(cloud.IsValid(&error)) << "dense.cloud: " << error;
  DYPHO_CHECK_INPUT(queue_capacity >= 1) << "dense.queue_capacity must be >= 1 (got " << queue_capacity << ")";
}

DenseMapper::DenseMapper(const Camera& camera, const DenseMapOptions& options, bool synchronous)
    : camera_(camera), options_(options), synchronous_(synchronous), map_(options.map) {
  options.Validate();
  camera.Validate("dense map camera");
  DYPHO_CHECK_INPUT(!camera.HasDistortion()) << "dense map: the camera must be an ideal pinhole (no distortion)";
  if (!synchronous_) thread_ = std::thread([this] { Loop(); });
}

DenseMapper::~DenseMapper() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  queue_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void DenseMapper::Add(int id, KeyframeInput keyframe) {
  DYPHO_CHECK_INPUT(FinitePose(keyframe.cam_from_world)) << "dense map: pose of keyframe " << id << " is not finite";
  const int w = camera_.width, h = camera_.height;
  auto size_ok = [&](const auto& image, int channels) {
    return image.width() == w && image.height() == h && image.channels() == channels;
  };
  DYPHO_CHECK_INPUT(size_ok(keyframe.rgb, 3)) << "dense map: keyframe " << id << ": rgb is not " << w << "x" << h << "x3";
  DYPHO_CHECK_INPUT(keyframe.depth.empty() || size_ok(keyframe.depth, 1))
      << "dense map: keyframe " << id << ": depth is not " << w << "x" << h << "x1";
  DYPHO_CHECK_INPUT(keyframe.dynamic_mask.empty() || size_ok(keyframe.dynamic_mask, 1))
      << "dense map: keyframe " << id << ": dynamic_mask is not " << w << "x" << h << "x1";
  std::unique_lock<std::mutex> lock(queue_mutex_);
  DYPHO_CHECK_INPUT(ids_.insert(id).second) << "dense map: keyframe " << id << " was already added";
  if (synchronous_) {
    lock.unlock();
    std::lock_guard<std::mutex> map_lock(map_mutex_);
    Apply(AddJob{id, std::move(keyframe)});
    return;
  }
  space_cv_.wait(lock, [this] { return queued_keyframes_ < options_.queue_capacity || stop_; });
  queue_.push_back(AddJob{id, std::move(keyframe)});
  ++queued_keyframes_;
  lock.unlock();
  queue_cv_.notify_all();
}

void DenseMapper::SetPose(int id, const Rigid3d& cam_from_world) {
  DYPHO_CHECK_INPUT(FinitePose(cam_from_world)) << "dense map: pose of keyframe " << id << " is not finite";
  std::unique_lock<std::mutex> lock(queue_mutex_);
  DYPHO_CHECK_INPUT(ids_.count(id) > 0) << "dense map: no keyframe " << id << " (pose update for an unknown keyframe)";
  if (synchronous_) {
    lock.unlock();
    std::lock_guard<std::mutex> map_lock(map_mutex_);
    Apply(PoseJob{id, cam_from_world});
    return;
  }
  queue_.push_back(PoseJob{id, cam_from_world});
  lock.unlock();
  queue_cv_.notify_all();
}

bool DenseMapper::Has(int id) const {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return ids_.count(id) > 0;
}

void DenseMapper::Apply(Job job) {
  if (auto* add = std::get_if<AddJob>(&job)) {
    const auto start = std::chrono::steady_clock::now();
    KeyframePoints points = ExtractKeyframePoints(camera_, add->keyframe, options_.points, options_.map.voxel_size);
    if (points.size() == 0) ++stats_.empty_keyframes;
    map_.AddKeyframe(add->id, add->keyframe.cam_from_world, std::move(points));
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    ++stats_.keyframes_added;
    stats_.total_ms += ms;
    stats_.max_ms = std::max(stats_.max_ms, ms);
  } else {
    const PoseJob& pose = std::get<PoseJob>(job);
    const Rigid3d before = map_.KeyframePose(pose.id);
    map_.SetKeyframePose(pose.id, pose.cam_from_world);
    if (!(before.translation == pose.cam_from_world.translation &&
          before.rotation.coeffs() == pose.cam_from_world.rotation.coeffs())) {
      ++stats_.pose_updates;
    }
  }
}

void DenseMapper::Loop() {
  SetCurrentThreadName("dypho-dense");
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping, nothing left
      job = std::move(queue_.front());
      queue_.pop_front();
      if (std::holds_alternative<AddJob>(job)) --queued_keyframes_;
      busy_ = true;
    }
    space_cv_.notify_all();
    try {
      std::lock_guard<std::mutex> lock(map_mutex_);
      Apply(std::move(job));
    } catch (const std::exception& e) {
      // Add and SetPose checked the input already; log what is left.
      DYPHO_LOG(Error) << "dense map: " << e.what();
    }
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      busy_ = false;
    }
    idle_cv_.notify_all();
  }
}

void DenseMapper::Wait() const {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  idle_cv_.wait(lock, [this] { return queue_.empty() && !busy_; });
}

ColoredPoints DenseMapper::Cloud() const {
  Wait();
  std::lock_guard<std::mutex> lock(map_mutex_);
  return DenseCloud(map_, options_.cloud);
}

void DenseMapper::Save(const std::string& path) const { SavePointCloudPly(Cloud(), path); }

DenseMapStats DenseMapper::stats() const {
  Wait();
  std::lock_guard<std::mutex> lock(map_mutex_);
  DenseMapStats s = stats_;
  s.map = map_.stats();
  return s;
}

}  // namespace dypho
