// EngineImpl (engine/api_impl.h): the mapping thread, the final refinement,
// the queries of the map and Save.
#include <chrono>
#include <string>
#include <thread>

#include "common/check.h"
#include "common/files.h"
#include "common/thread_name.h"
#include "engine/api_impl.h"
#include "engine/eval/trajectory.h"
#include "engine/export/ply.h"

namespace dypho {

int EngineImpl::Refine(int steps) {
  DYPHO_CHECK_INPUT(steps >= 0) << "Refine: steps must be >= 0 (got " << steps << ")";
  int done = 0;
  for (; done < steps; ++done) {
    std::lock_guard<std::mutex> lock(map_mutex_);
    if (mapper_->num_keyframes() == 0) break;
    mapper_->Optimize(1);
  }
  return done;
}

int EngineImpl::RequestRefine(int steps) {
  DYPHO_CHECK_INPUT(steps >= 0) << "RequestRefine: steps must be >= 0 (got " << steps << ")";
  if (options_.synchronous) return Refine(steps);
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    pending_refine_ += steps;
  }
  queue_cv_.notify_all();
  return steps;
}

Trajectory EngineImpl::MappedKeyframes() const {
  const std::unique_lock<std::mutex> lock = ReaderLock();
  return MappedKeyframesLocked();
}

Trajectory EngineImpl::MappedKeyframesLocked() const {
  Trajectory keyframes;
  for (int k = 0; k < mapper_->num_keyframes(); ++k) {
    keyframes.timestamps.push_back(mapper_->KeyframeTimestamp(k));
    keyframes.world_from_cam.push_back(mapper_->KeyframePose(k).Inverse());
  }
  return keyframes;
}

EngineRender EngineImpl::Render(const Camera& camera, const Rigid3d& cam_from_world,
                                kernels::CompositeMode mode) const {
  DYPHO_CHECK_INPUT(FinitePose(cam_from_world)) << "Render: cam_from_world is not finite";
  std::string error;
  DYPHO_CHECK_INPUT(camera.IsValid(&error)) << "Render: camera: " << error;
  return RenderForHost(Map(), camera, cam_from_world, mode, options_);
}

GaussianCloud EngineImpl::Map() const {
  const std::unique_lock<std::mutex> lock = ReaderLock();
  return mapper_->Cloud();
}

EngineStatus EngineImpl::Status() const {
  EngineStatus s = QueueStatus();
  const std::unique_lock<std::mutex> lock = ReaderLock();
  const MapperStats ms = mapper_->stats();
  s.mapped_keyframes = ms.num_keyframes;
  s.num_gaussians = ms.num_gaussians;
  s.iterations = ms.iterations;
  s.last_loss = ms.last_loss;
  std::lock_guard<std::mutex> finish_lock(queue_mutex_);
  s.final_steps = finish_.final_steps;
  s.final_stop = finish_.final_stop;
  s.carved_gaussians = finish_.carved;
  s.holdout_frames = finish_.holdout_frames;
  s.holdout_loss_start = finish_.holdout_loss_start;
  s.holdout_loss_end = finish_.holdout_loss_end;
  return s;
}

EngineStatus EngineImpl::QueueStatus() const {
  EngineStatus s;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    s.keyframes = next_id_;
    const KeyframeStoreStats st = store_.stats();
    s.queued_keyframes = st.waiting;
    s.late_keyframes = st.total_packed;
    s.spilled_keyframes = st.total_spilled;
    s.peak_waiting_mb = st.peak_packed_bytes / 1048576.0;
    s.push_waits = push_waits_;
    s.shortened_keyframes = shortened_count_;
    s.keyframe_pair_depths = pair_depths_;
    s.keyframe_pair_depth_ms = pair_depth_us_ / 1000.0;
    const KeyframeMaskCounts masks = keyframe_masks_.counts();
    s.keyframe_masks = masks.asked;
    s.keyframe_masks_on_push = masks.on_push;
    s.keyframe_mask_ms = masks.ms;
    s.mapped_keyframes = static_cast<int>(mapper_ids_.size());
  }
  std::lock_guard<std::mutex> lock(push_mutex_);
  s.frames = frames_;
  if (seen_through_) {
    s.held_keyframes = seen_through_->held();
    s.queued_keyframes += s.held_keyframes;
    s.seen_through_pixels = seen_through_->masked_pixels();
  }
  return s;
}

void EngineImpl::WaitUntilIdle() {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  idle_cv_.wait(lock, [this] { return store_.empty() && in_flight_id_ < 0 && !busy_ && pending_refine_ == 0; });
}

int EngineImpl::Finish(const std::function<void(int done, int planned)>& progress,
                       std::optional<std::chrono::steady_clock::time_point> deadline) {
  FlushCandidate();
  WaitUntilIdle();
  // The held-back frames, unpacked once.
  const std::vector<KeyframeInput> holdout = holdout_.Unpacked();
  FinishHooks hooks;
  hooks.holdout_frames = static_cast<int>(holdout.size());
  {
    std::lock_guard<std::mutex> lock(map_mutex_);
    hooks.keyframes = mapper_->num_keyframes();
  }
  hooks.step_gate = [this] { StepGate(); };
  hooks.optimize_all = [this](int steps) {
    std::lock_guard<std::mutex> lock(map_mutex_);
    mapper_->OptimizeAll(steps);
  };
  hooks.carve = [this](int votes) {
    std::lock_guard<std::mutex> lock(map_mutex_);
    return mapper_->CarveFreeSpace(votes);
  };
  hooks.holdout_loss = [&] {
    std::lock_guard<std::mutex> lock(map_mutex_);
    return HoldoutLoss(*mapper_, holdout, options_.mapper.refine_poses);
  };
  const FinishSummary summary = RunFinalRefinement(options_, hooks, progress, deadline);
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    finish_ = summary;
  }
  return summary.final_steps;
}

void EngineImpl::Save(const std::string& dir) const {
  MakeOutputDirectory(dir);
  GaussianCloud cloud;
  Trajectory keyframes;
  {
    std::lock_guard<std::mutex> lock(map_mutex_);
    cloud = mapper_->Cloud();
    keyframes = MappedKeyframesLocked();
  }
  SavePly(cloud, JoinPath(dir, "map.ply"));
  WriteTumTrajectory(JoinPath(dir, "keyframes.txt"), keyframes);
  if (dense_) SaveDenseCloud(JoinPath(dir, "dense.ply"));
}

void EngineImpl::SaveDenseCloud(const std::string& path) const {
  DYPHO_CHECK_INPUT(dense_ != nullptr) << "SaveDenseCloud(" << path
                                       << "): the dense map is off (EngineOptions.dense.enabled)";
  SyncDensePoses();
  dense_->Save(path);
}

DenseMapStats EngineImpl::DenseStatus() const {
  if (!dense_) return DenseMapStats();
  SyncDensePoses();
  return dense_->stats();
}

void EngineImpl::SyncDensePoses() const {
  std::map<int, int> ids;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    ids = mapper_ids_;
  }
  const std::unique_lock<std::mutex> lock = ReaderLock();
  for (const auto& [id, mapper_id] : ids) dense_->SetPose(id, mapper_->KeyframePose(mapper_id));
}

std::unique_lock<std::mutex> EngineImpl::ReaderLock() const {
  readers_waiting_.fetch_add(1);
  std::unique_lock<std::mutex> lock(map_mutex_);
  readers_waiting_.fetch_sub(1);
  return lock;
}

void EngineImpl::StepGate() const {
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(100);
  while (readers_waiting_.load() > 0 && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
}

void EngineImpl::ResolvePairDepthCounted(KeyframeInput* input) {
  if (input->right_rgb.empty()) return;
  pair_depth_us_ += static_cast<long>(1000.0 * ResolvePairDepth(input, options_));
  ++pair_depths_;
}

void EngineImpl::MapOne(int id, KeyframeInput input) {
  ResolvePairDepthCounted(&input);
  keyframe_masks_.Resolve(&input);
  int mapper_id;
  {
    std::lock_guard<std::mutex> lock(map_mutex_);
    mapper_id = mapper_->AddKeyframe(input);
  }
  mapper_ids_[id] = mapper_id;
  if (dense_) dense_->Add(id, std::move(input));
  for (int i = 0; i < options_.iterations_per_keyframe; ++i) {
    std::lock_guard<std::mutex> lock(map_mutex_);
    mapper_->Optimize(1);
  }
}

void EngineImpl::MappingLoop() {
  SetCurrentThreadName("dypho-map");
  for (;;) {
    std::pair<int, KeyframeInput> p;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return stop_ || !store_.empty() || pending_refine_ > 0; });
      if (stop_) return;
      if (pending_refine_ > 0) {  // RequestRefine's steps go first
        const int steps = pending_refine_;
        pending_refine_ = 0;
        busy_ = true;
        lock.unlock();
        RunRequestedRefine(steps);
        continue;
      }
      p = store_.Take();
      in_flight_id_ = p.first;
      in_flight_pose_ = p.second.cam_from_world;
    }
    space_cv_.notify_all();
    ResolvePairDepthCounted(&p.second);
    keyframe_masks_.Resolve(&p.second);
    int mapper_id;
    {
      std::lock_guard<std::mutex> lock(map_mutex_);
      mapper_id = mapper_->AddKeyframe(p.second);
    }
    std::optional<Rigid3d> deferred;
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      mapper_ids_[p.first] = mapper_id;
      const auto it = deferred_updates_.find(p.first);
      if (it != deferred_updates_.end()) {
        deferred = it->second;
        deferred_updates_.erase(it);
      }
      // The dense thread gets the keyframe (at its corrected pose) before
      // the id is visible as mapped, so that its pose updates follow it.
      if (dense_) {
        if (deferred) p.second.cam_from_world = *deferred;
        dense_->Add(p.first, std::move(p.second));
      }
      in_flight_id_ = -1;
      busy_ = true;
    }
    if (deferred) {
      std::lock_guard<std::mutex> lock(map_mutex_);
      mapper_->SetKeyframePose(mapper_id, *deferred);
    }
    for (int i = 0; i < options_.iterations_per_keyframe; ++i) {
      {
        std::lock_guard<std::mutex> lock(queue_mutex_);
        if (stop_) break;
        if (options_.min_iterations_when_behind >= 0 && i >= options_.min_iterations_when_behind && !store_.empty()) {
          ++shortened_count_;
          break;
        }
      }
      StepGate();
      std::lock_guard<std::mutex> lock(map_mutex_);
      mapper_->Optimize(1);
    }
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      busy_ = false;
    }
    idle_cv_.notify_all();
  }
}

void EngineImpl::RunRequestedRefine(int steps) {
  for (int i = 0; i < steps; ++i) {
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      if (stop_) break;
    }
    StepGate();
    std::lock_guard<std::mutex> lock(map_mutex_);
    if (mapper_->num_keyframes() == 0) break;
    mapper_->Optimize(1);
  }
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    busy_ = false;
  }
  idle_cv_.notify_all();
}

}  // namespace dypho
