#include "engine/api.h"

#include <string>

#include "common/check.h"
#include "common/logging.h"
#include "engine/api_impl.h"
#include "tracker/cv_view.h"

namespace dypho {

EngineImpl::EngineImpl(const EngineOptions& options)
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

EngineImpl::~EngineImpl() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  queue_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

PushResult EngineImpl::PushFrame(const FrameBuffers& frame, const Rigid3d* cam_from_world) {
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
  DYPHO_LOG(Debug) << std::fixed << "keyframe selector: frame " << frame.timestamp << " new content "
                   << decision.new_content << " sharpness " << decision.sharpness << " (keyframes seeing it "
                   << decision.seen_sharpness << ")" << (decision.keep ? " kept" : "")
                   << (decision.emit ? " emitted" : "");
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

int EngineImpl::EnqueueOrHold(KeyframeInput input) {
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

void EngineImpl::ReleaseHeld(bool all) {
  for (auto& [id, input] : seen_through_->Release(all)) Enqueue(std::move(input), id);
}

int EngineImpl::Enqueue(KeyframeInput input, int given_id) {
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

void EngineImpl::FlushCandidate() {
  std::lock_guard<std::mutex> push_lock(push_mutex_);
  if (selector_.Flush() && candidate_) {
    EnqueueOrHold(TakeCandidate());
  }
  if (seen_through_) ReleaseHeld(true);
}

KeyframeInput EngineImpl::TakeCandidate() {
  KeyframeSource source = std::move(*candidate_);
  candidate_.reset();
  if (options_.keyframe_mask) keyframe_masks_.Add(source.pushed);  // asked before mapping (keyframe_masks.h)
  return MakeKeyframeInput(undistort_, std::move(source), true);
}

void EngineImpl::UpdateKeyframePose(int id, const Rigid3d& cam_from_world) {
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

bool EngineImpl::UpdateCandidatePose(double timestamp, const Rigid3d& cam_from_world) {
  DYPHO_CHECK_INPUT(FinitePose(cam_from_world)) << "UpdateCandidatePose: pose at t=" << timestamp << " is not finite";
  std::lock_guard<std::mutex> push_lock(push_mutex_);
  if (!candidate_ || candidate_->timestamp != timestamp) return false;
  candidate_->cam_from_world = cam_from_world;
  return true;
}

Rigid3d EngineImpl::KeyframePose(int id) const {
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

int EngineImpl::MapperIdLocked(int id, const char* what) const {
  DYPHO_CHECK_INPUT(id >= 0 && id < next_id_) << what << ": no keyframe " << id << " (" << next_id_ << " so far)";
  const auto it = mapper_ids_.find(id);
  DYPHO_CHECK(it != mapper_ids_.end()) << "keyframe " << id << " is neither waiting nor mapped";
  return it->second;
}

std::unique_ptr<Engine> Engine::Create(const EngineOptions& options) {
  options.Validate();
  return std::make_unique<EngineImpl>(options);
}

}  // namespace dypho
