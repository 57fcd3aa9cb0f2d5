#include "engine/api.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>

#include "common/check.h"
#include "common/files.h"
#include "common/logging.h"
#include "common/thread_name.h"
#include "engine/api_finish.h"
#include "engine/api_frames.h"
#include "engine/dense/dense_mapper.h"
#include "engine/eval/trajectory.h"
#include "engine/export/ply.h"
#include "engine/holdout_frames.h"
#include "engine/keyframe_masks.h"
#include "engine/map/keyframe_store.h"
#include "engine/map/sensor_model.h"
#include "engine/map/undistort.h"
#include "tracker/cv_view.h"
#include "tracker/orb_tracker.h"

namespace dypho {

namespace {

class EngineImpl final : public Engine {
 public:
  explicit EngineImpl(const EngineOptions& options)
      : options_(options),
        undistort_(options.camera),
        selector_(options.keyframes, options.camera),
        store_(StoreOptionsFor(options)),
        holdout_(options.holdout_every, options.max_holdout_frames, !options.synchronous) {
    mapper_ = std::make_unique<Mapper>(undistort_.pinhole(), options.mapper);
    if (options.track_when_no_pose) tracker_ = std::make_unique<OrbTracker>(options.camera);
    if (options.seen_through.enabled)
      seen_through_ = std::make_unique<SeenThroughQueue>(undistort_.pinhole(), options.seen_through);
    if (options.dense.enabled) dense_ = std::make_unique<DenseMapper>(undistort_.pinhole(), options.dense, options.synchronous);
    if (!options.synchronous) thread_ = std::thread([this] { MappingLoop(); });
  }

  ~EngineImpl() override {
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      stop_ = true;
    }
    queue_cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  PushResult PushFrame(const FrameBuffers& frame, const Rigid3d* cam_from_world) override {
    PushedFrame pushed = CopyPushedFrame(frame, cam_from_world, options_);
    const ImageU8& rgb = pushed.rgb;
    const ImageF& depth = pushed.depth;
    const ImageU8& mask = pushed.mask;

    PushResult result;
    std::lock_guard<std::mutex> push_lock(push_mutex_);  // one frame at a time through tracker and selector
    ++frames_;
    if (cam_from_world) {
      result.has_pose = true;
      result.cam_from_world = *cam_from_world;
    } else {
      DYPHO_CHECK_INPUT(tracker_ != nullptr)
          << "PushFrame: no pose given and EngineOptions.track_when_no_pose is off";
      TrackerFrame tf;
      tf.timestamp = frame.timestamp;
      tf.image = CvView(rgb);
      if (!depth.empty()) tf.depth = CvView(depth);
      if (!mask.empty()) tf.dynamic_mask = CvView(mask);
      const TrackResult tr = tracker_->Track(tf);
      if (!IsTracked(tr.status)) {
        result.message = std::string("tracker: ") + TrackStatusName(tr.status) +
                         (tr.message.empty() ? "" : " (" + tr.message + ")");
        last_pushed_pose_.reset();
        return result;
      }
      result.has_pose = true;
      result.cam_from_world = tr.cam_from_world;
    }
    const Eigen::Vector3d omega =
        frame.angular_velocity
            ? *frame.angular_velocity
            : AngularVelocitySince(last_pushed_pose_, last_pushed_time_, result.cam_from_world, frame.timestamp);
    const std::optional<Rigid3d> previous_pose = last_pushed_pose_;
    const double previous_time = last_pushed_time_;
    last_pushed_pose_ = result.cam_from_world;
    last_pushed_time_ = frame.timestamp;
    if (depth.empty()) return result;
    // What a keyframe input is made from: the frame as pushed and the
    // motion around it. A keyframe candidate keeps it and is made into a
    // KeyframeInput (undistortion, depth at the colour time) only when the
    // selector emits it: most candidates are replaced by a sharper frame of
    // their window before that.
    KeyframeSource source;
    source.timestamp = frame.timestamp;
    source.cam_from_world = result.cam_from_world;
    source.omega = omega;
    source.previous_pose = previous_pose;
    source.previous_time = previous_time;
    source.depth_dt = frame.depth_timestamp ? *frame.depth_timestamp - frame.timestamp : 0.0;
    long long frame_index = -1;
    if (seen_through_) {
      // The pinhole depth at the colour image's pose, once: seen_through_
      // takes every frame's, a keyframe or held-back frame keeps it.
      source.pinhole_depth = KeyframeSourceDepth(undistort_, pushed.depth, source);
      frame_index = seen_through_->Add(*source.pinhole_depth, result.cam_from_world, omega);
      ReleaseHeld(false);
    }
    const KeyframeDecision decision = selector_.Offer(result.cam_from_world, depth, rgb, mask);
    if (decision.keep) {
      source.pushed = std::move(pushed);
      source.features = frame.features;
      candidate_ = std::move(source);
      candidate_frame_ = frame_index;
    } else if (holdout_.Due()) {
      source.pushed = std::move(pushed);
      source.features = frame.features;
      // Made (undistorted) and packed on the held-back frames' thread.
      auto owned = std::make_shared<KeyframeSource>(std::move(source));
      holdout_.Add([this, owned] { return MakeKeyframeInput(undistort_, std::move(*owned), false); });
    }
    if (!decision.emit) return result;
    DYPHO_CHECK(candidate_.has_value()) << "keyframe selector emitted without a candidate";
    KeyframeInput input = TakeCandidate();
    result.keyframe = true;
    result.keyframe_timestamp = input.timestamp;
    result.keyframe_id = EnqueueOrHold(std::move(input));
    return result;
  }

  // Enqueue, or with seen_through on, hold the keyframe for the frames after
  // it (its id now). Caller holds push_mutex_.
  int EnqueueOrHold(KeyframeInput input) {
    if (!seen_through_) return Enqueue(std::move(input));
    int id;
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      id = next_id_++;
    }
    seen_through_->Hold(id, std::move(input), candidate_frame_);
    ReleaseHeld(false);
    return id;
  }

  // The held keyframes whose window has passed (all: every one) to the
  // mapper. Caller holds push_mutex_.
  void ReleaseHeld(bool all) {
    for (auto& [id, input] : seen_through_->Release(all)) Enqueue(std::move(input), id);
  }

  // Hands a keyframe to the mapping thread (or maps it, synchronous) and
  // returns its id. Caller holds push_mutex_.
  // `id` >= 0: an id given out before (a held keyframe).
  int Enqueue(KeyframeInput input, int given_id = -1) {
    if (options_.synchronous) {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      const int id = given_id >= 0 ? given_id : next_id_++;
      MapOne(id, std::move(input));
      return id;
    }
    int id;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      id = given_id >= 0 ? given_id : next_id_++;
      bool waited = false;
      // Memory full and no spill folder: wait until the mapping thread takes one.
      while (!store_.Put(id, input)) {
        waited = true;
        space_cv_.wait(lock);
      }
      if (waited) ++push_waits_;
    }
    queue_cv_.notify_all();
    return id;
  }

  // The end of the stream: a keyframe candidate still waiting for the end of
  // its sharpness window becomes a keyframe.
  void FlushCandidate() {
    std::lock_guard<std::mutex> push_lock(push_mutex_);
    if (selector_.Flush() && candidate_) {
      EnqueueOrHold(TakeCandidate());
    }
    if (seen_through_) ReleaseHeld(true);
  }

  // The candidate as a keyframe input; EngineOptions::keyframe_mask's pixels
  // join it before it is mapped. Caller holds push_mutex_.
  KeyframeInput TakeCandidate() {
    KeyframeSource source = std::move(*candidate_);
    candidate_.reset();
    if (options_.keyframe_mask) keyframe_masks_.Add(source.pushed);  // asked before mapping (keyframe_masks.h)
    return MakeKeyframeInput(undistort_, std::move(source), true);
  }

  void UpdateKeyframePose(int id, const Rigid3d& cam_from_world) override {
    DYPHO_CHECK_INPUT(FinitePose(cam_from_world)) << "UpdateKeyframePose: pose of keyframe " << id << " is not finite";
    if (seen_through_) {
      // Held keyframes leave the queue only under push_mutex_ (ReleaseHeld).
      std::lock_guard<std::mutex> push_lock(push_mutex_);
      if (seen_through_->SetPose(id, cam_from_world)) return;
    }
    std::unique_lock<std::mutex> lock(queue_mutex_);
    if (store_.SetPose(id, cam_from_world)) return;
    // An item being mapped right now is applied after its insertion.
    if (in_flight_id_ == id) {
      deferred_updates_[id] = cam_from_world;
      return;
    }
    const int mapper_id = MapperIdLocked(id, "UpdateKeyframePose");
    lock.unlock();
    // As a reader: the mapping loop lets it in before its next step (a plain
    // lock waited behind step after step: a loop's 12 updates stalled the
    // frame loop for seconds).
    const std::unique_lock<std::mutex> map_lock = ReaderLock();
    mapper_->SetKeyframePose(mapper_id, cam_from_world);
    // Under the map lock, so that the dense map gets the poses in the
    // mapper's order (SyncDensePoses reads them under it too).
    if (dense_) dense_->SetPose(id, cam_from_world);
  }

  bool UpdateCandidatePose(double timestamp, const Rigid3d& cam_from_world) override {
    DYPHO_CHECK_INPUT(FinitePose(cam_from_world)) << "UpdateCandidatePose: pose at t=" << timestamp << " is not finite";
    std::lock_guard<std::mutex> push_lock(push_mutex_);
    if (!candidate_ || candidate_->timestamp != timestamp) return false;
    candidate_->cam_from_world = cam_from_world;
    return true;
  }

  int Refine(int steps) override {
    DYPHO_CHECK_INPUT(steps >= 0) << "Refine: steps must be >= 0 (got " << steps << ")";
    int done = 0;
    for (; done < steps; ++done) {
      std::lock_guard<std::mutex> lock(map_mutex_);
      if (mapper_->num_keyframes() == 0) break;
      mapper_->Optimize(1);
    }
    return done;
  }

  int RequestRefine(int steps) override {
    DYPHO_CHECK_INPUT(steps >= 0) << "RequestRefine: steps must be >= 0 (got " << steps << ")";
    if (options_.synchronous) return Refine(steps);
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      pending_refine_ += steps;
    }
    queue_cv_.notify_all();
    return steps;
  }

  Rigid3d KeyframePose(int id) const override {
    Rigid3d waiting;
    if (seen_through_) {
      std::lock_guard<std::mutex> push_lock(push_mutex_);
      if (seen_through_->GetPose(id, &waiting)) return waiting;
    }
    std::unique_lock<std::mutex> lock(queue_mutex_);
    if (store_.GetPose(id, &waiting)) return waiting;
    // Being inserted right now: its pose, or the correction waiting for it.
    if (in_flight_id_ == id) {
      const auto it = deferred_updates_.find(id);
      return it != deferred_updates_.end() ? it->second : in_flight_pose_;
    }
    const int mapper_id = MapperIdLocked(id, "KeyframePose");
    lock.unlock();
    const std::unique_lock<std::mutex> map_lock = ReaderLock();
    return mapper_->KeyframePose(mapper_id);
  }

  Trajectory MappedKeyframes() const override {
    const std::unique_lock<std::mutex> lock = ReaderLock();
    return MappedKeyframesLocked();
  }

  // Caller holds map_mutex_.
  Trajectory MappedKeyframesLocked() const {
    Trajectory keyframes;
    for (int k = 0; k < mapper_->num_keyframes(); ++k) {
      keyframes.timestamps.push_back(mapper_->KeyframeTimestamp(k));
      keyframes.world_from_cam.push_back(mapper_->KeyframePose(k).Inverse());
    }
    return keyframes;
  }

  EngineRender Render(const Camera& camera, const Rigid3d& cam_from_world, kernels::CompositeMode mode) const override {
    DYPHO_CHECK_INPUT(FinitePose(cam_from_world)) << "Render: cam_from_world is not finite";
    std::string error;
    DYPHO_CHECK_INPUT(camera.IsValid(&error)) << "Render: camera: " << error;
    return RenderForHost(Map(), camera, cam_from_world, mode, options_);
  }

  GaussianCloud Map() const override {
    const std::unique_lock<std::mutex> lock = ReaderLock();
    return mapper_->Cloud();
  }

  EngineStatus Status() const override {
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

  EngineStatus QueueStatus() const override {
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

  void EndOfStream() override { FlushCandidate(); }

  void WaitUntilIdle() override {
    std::unique_lock<std::mutex> lock(queue_mutex_);
    idle_cv_.wait(lock, [this] { return store_.empty() && in_flight_id_ < 0 && !busy_ && pending_refine_ == 0; });
  }

  int Finish(const std::function<void(int done, int planned)>& progress,
             std::optional<std::chrono::steady_clock::time_point> deadline) override {
    FlushCandidate();
    WaitUntilIdle();
    // The held-back frames, unpacked once.
    const std::vector<KeyframeInput> holdout = holdout_.Unpacked();
    FinishHooks hooks;
    hooks.holdout_frames = static_cast<int>(holdout.size());
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

  void Save(const std::string& dir) const override {
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

  void SaveDenseCloud(const std::string& path) const override {
    DYPHO_CHECK_INPUT(dense_ != nullptr) << "SaveDenseCloud(" << path << "): the dense map is off (EngineOptions.dense.enabled)";
    SyncDensePoses();
    dense_->Save(path);
  }

  DenseMapStats DenseStatus() const override {
    if (!dense_) return DenseMapStats();
    SyncDensePoses();
    return dense_->stats();
  }

 private:
  // The mapper's keyframe poses (refined, corrected) to the dense map: a
  // keyframe whose pose changed moves its points.
  void SyncDensePoses() const {
    std::map<int, int> ids;
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      ids = mapper_ids_;
    }
    const std::unique_lock<std::mutex> lock = ReaderLock();
    for (const auto& [id, mapper_id] : ids) dense_->SetPose(id, mapper_->KeyframePose(mapper_id));
  }

  int MapperIdLocked(int id, const char* what) const {
    DYPHO_CHECK_INPUT(id >= 0 && id < next_id_) << what << ": no keyframe " << id << " (" << next_id_ << " so far)";
    const auto it = mapper_ids_.find(id);
    DYPHO_CHECK(it != mapper_ids_.end()) << "keyframe " << id << " is neither waiting nor mapped";
    return it->second;
  }

  // The map lock for a reader of the host's threads (Map, Render, Status,
  // KeyframePose). std::mutex is not fair: the mapping loop, which re-takes
  // the lock for every optimisation step, could win it again and again and
  // starve a reader (seen in dypho run under load: a render thread got no map
  // for a whole TUM run). Readers announce themselves; the mapping loop lets
  // them go first (StepGate).
  std::unique_lock<std::mutex> ReaderLock() const {
    readers_waiting_.fetch_add(1);
    std::unique_lock<std::mutex> lock(map_mutex_);
    readers_waiting_.fetch_sub(1);
    return lock;
  }

  // Before the mapping loop takes the map lock for a step: wait (at most
  // 100 ms) while a reader is waiting for it.
  void StepGate() const {
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(100);
    while (readers_waiting_.load() > 0 && std::chrono::steady_clock::now() < until) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }

  // A keyframe's dense depth from its pair (keyframe_depth_from_pair), counted.
  void ResolvePairDepthCounted(KeyframeInput* input) {
    if (input->right_rgb.empty()) return;
    pair_depth_us_ += static_cast<long>(1000.0 * ResolvePairDepth(input, options_));
    ++pair_depths_;
  }

  // Inserts and optimises one keyframe; queue_mutex_ must be held by the
  // caller in synchronous mode (the map lock is taken per step).
  void MapOne(int id, KeyframeInput input) {
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

  void MappingLoop() {
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
          if (options_.min_iterations_when_behind >= 0 && i >= options_.min_iterations_when_behind &&
              !store_.empty()) {
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

  // RequestRefine's steps on the mapping thread (busy_ set by the caller).
  void RunRequestedRefine(int steps) {
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

  const EngineOptions options_;
  const Undistorter undistort_;
  KeyframeSelector selector_;
  std::optional<KeyframeSource> candidate_;  // the selector's kept keyframe candidate (push_mutex_)
  long long candidate_frame_ = -1;  // the candidate's index in seen_through_ (push_mutex_)
  std::unique_ptr<SeenThroughQueue> seen_through_;  // held keyframes (push_mutex_); null when off
  std::unique_ptr<OrbTracker> tracker_;
  std::unique_ptr<Mapper> mapper_;
  std::unique_ptr<DenseMapper> dense_;  // the dense point-cloud map (null when off); thread-safe itself

  mutable std::mutex push_mutex_;   // PushFrame's tracker and selector
  mutable std::mutex queue_mutex_;  // queue_, ids
  mutable std::mutex map_mutex_;    // mapper_
  mutable std::atomic<int> readers_waiting_{0};  // host threads waiting for map_mutex_ (ReaderLock)
  std::condition_variable queue_cv_, idle_cv_, space_cv_;
  KeyframeStore store_;            // keyframes waiting for the mapping thread (queue_mutex_)
  std::map<int, int> mapper_ids_;  // engine keyframe id -> mapper keyframe id
  std::map<int, Rigid3d> deferred_updates_;
  int next_id_ = 0;
  int in_flight_id_ = -1;
  Rigid3d in_flight_pose_;  // the in-flight keyframe's pose as queued
  int push_waits_ = 0;             // PushFrame calls that waited for room (queue_mutex_)
  int shortened_count_ = 0;        // keyframes whose optimisation was cut short (queue_mutex_)
  std::atomic<int> pair_depths_{0};       // keyframe depths computed from the pair
  std::atomic<long> pair_depth_us_{0};    // their disparity time [us]
  FinishSummary finish_;           // the last Finish (queue_mutex_)
  HoldoutFrames holdout_;          // held-back frames (offered under push_mutex_)
  // Keyframes waiting for EngineOptions::keyframe_mask (thread-safe); at most
  // 24 whole frames (~58 MB at 640x480), the rest answered on push.
  KeyframeMasks keyframe_masks_{options_, undistort_, 24};
  int frames_ = 0;
  // The last pushed frame with a pose (push_mutex_): the angular velocity of
  // the next one comes from it when the host gives none.
  std::optional<Rigid3d> last_pushed_pose_;
  double last_pushed_time_ = 0.0;  // [s]
  bool busy_ = false;  // optimising after an insertion or RequestRefine
  int pending_refine_ = 0;  // RequestRefine's steps not yet started (queue_mutex_)
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace

std::unique_ptr<Engine> Engine::Create(const EngineOptions& options) {
  options.Validate();
  return std::make_unique<EngineImpl>(options);
}

}  // namespace dypho
