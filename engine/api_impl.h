// The engine behind Engine::Create (engine/api.h). Internal to the engine
// library: api.cc holds the frames' side (PushFrame, the keyframe candidate,
// the queue, pose updates), api_mapping.cc the mapping thread, the final
// refinement, the queries and Save.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "engine/api.h"
#include "engine/api_finish.h"
#include "engine/api_frames.h"
#include "engine/dense/dense_mapper.h"
#include "engine/dynamic/seen_through.h"
#include "engine/holdout_frames.h"
#include "engine/keyframe_masks.h"
#include "engine/map/keyframe_selector.h"
#include "engine/map/keyframe_store.h"
#include "engine/map/mapper.h"
#include "engine/map/undistort.h"
#include "tracker/orb_tracker.h"

namespace dypho {

class EngineImpl final : public Engine {
 public:
  explicit EngineImpl(const EngineOptions &options);
  ~EngineImpl() override;

  // api.cc
  PushResult PushFrame(const FrameBuffers &frame, const Rigid3d *cam_from_world) override;
  void UpdateKeyframePose(int id, const Rigid3d &cam_from_world) override;
  bool UpdateCandidatePose(double timestamp, const Rigid3d &cam_from_world) override;
  Rigid3d KeyframePose(int id) const override;
  void EndOfStream() override { FlushCandidate(); }

  // api_mapping.cc
  int Refine(int steps) override;
  int RequestRefine(int steps) override;
  Trajectory MappedKeyframes() const override;
  EngineRender Render(const Camera &camera, const Rigid3d &cam_from_world, kernels::CompositeMode mode) const override;
  GaussianCloud Map() const override;
  EngineStatus Status() const override;
  EngineStatus QueueStatus() const override;
  void WaitUntilIdle() override;
  int Finish(const std::function<void(int done, int planned)> &progress,
             std::optional<std::chrono::steady_clock::time_point> deadline) override;
  void Save(const std::string &dir) const override;
  void SaveDenseCloud(const std::string &path) const override;
  DenseMapStats DenseStatus() const override;

 private:
  // The mapper's keyframe poses (refined, corrected) to the dense map: a
  // keyframe whose pose changed moves its points.
  void SyncDensePoses() const;

  // Enqueue, or with seen_through on, hold the keyframe for the frames after
  // it (its id now). Caller holds push_mutex_.
  int EnqueueOrHold(KeyframeInput input);

  // The held keyframes whose window has passed (all: every one) to the
  // mapper. Caller holds push_mutex_.
  void ReleaseHeld(bool all);

  // Hands a keyframe to the mapping thread (or maps it, synchronous) and
  // returns its id. Caller holds push_mutex_.
  // `id` >= 0: an id given out before (a held keyframe).
  int Enqueue(KeyframeInput input, int given_id = -1);

  // The end of the stream: a keyframe candidate still waiting for the end of
  // its sharpness window becomes a keyframe.
  void FlushCandidate();

  // The candidate as a keyframe input; EngineOptions::keyframe_mask's pixels
  // join it before it is mapped. Caller holds push_mutex_.
  KeyframeInput TakeCandidate();

  // Caller holds map_mutex_.
  Trajectory MappedKeyframesLocked() const;

  int MapperIdLocked(int id, const char *what) const;

  // The map lock for a reader of the host's threads (Map, Render, Status,
  // KeyframePose). std::mutex is not fair: the mapping loop, which re-takes
  // the lock for every optimisation step, could win it again and again and
  // starve a reader (seen in dypho run under load: a render thread got no map
  // for a whole TUM run). Readers announce themselves; the mapping loop lets
  // them go first (StepGate).
  std::unique_lock<std::mutex> ReaderLock() const;

  // Before the mapping loop takes the map lock for a step: wait (at most
  // 100 ms) while a reader is waiting for it.
  void StepGate() const;

  // A keyframe's dense depth from its pair (keyframe_depth_from_pair), counted.
  void ResolvePairDepthCounted(KeyframeInput *input);

  // Inserts and optimises one keyframe; queue_mutex_ must be held by the
  // caller in synchronous mode (the map lock is taken per step).
  void MapOne(int id, KeyframeInput input);

  void MappingLoop();

  // RequestRefine's steps on the mapping thread (busy_ set by the caller).
  void RunRequestedRefine(int steps);

  const EngineOptions options_;
  const Undistorter undistort_;
  KeyframeSelector selector_;
  std::optional<KeyframeSource> candidate_;         // the selector's kept keyframe candidate (push_mutex_)
  long long candidate_frame_ = -1;                  // the candidate's index in seen_through_ (push_mutex_)
  std::unique_ptr<SeenThroughQueue> seen_through_;  // held keyframes (push_mutex_); null when off
  std::unique_ptr<OrbTracker> tracker_;
  std::unique_ptr<Mapper> mapper_;
  std::unique_ptr<DenseMapper> dense_;  // the dense point-cloud map (null when off); thread-safe itself

  mutable std::mutex push_mutex_;                // PushFrame's tracker and selector
  mutable std::mutex queue_mutex_;               // queue_, ids
  mutable std::mutex map_mutex_;                 // mapper_
  mutable std::atomic<int> readers_waiting_{0};  // host threads waiting for map_mutex_ (ReaderLock)
  std::condition_variable queue_cv_, idle_cv_, space_cv_;
  KeyframeStore store_;            // keyframes waiting for the mapping thread (queue_mutex_)
  std::map<int, int> mapper_ids_;  // engine keyframe id -> mapper keyframe id
  std::map<int, Rigid3d> deferred_updates_;
  int next_id_ = 0;
  int in_flight_id_ = -1;
  Rigid3d in_flight_pose_;              // the in-flight keyframe's pose as queued
  int push_waits_ = 0;                  // PushFrame calls that waited for room (queue_mutex_)
  int shortened_count_ = 0;             // keyframes whose optimisation was cut short (queue_mutex_)
  std::atomic<int> pair_depths_{0};     // keyframe depths computed from the pair
  std::atomic<long> pair_depth_us_{0};  // their disparity time [us]
  FinishSummary finish_;                // the last Finish (queue_mutex_)
  HoldoutFrames holdout_;               // held-back frames (offered under push_mutex_)
  // Keyframes waiting for EngineOptions::keyframe_mask (thread-safe); at most
  // 24 whole frames (~58 MB at 640x480), the rest answered on push.
  KeyframeMasks keyframe_masks_{options_, undistort_, 24};
  int frames_ = 0;
  // The last pushed frame with a pose (push_mutex_): the angular velocity of
  // the next one comes from it when the host gives none.
  std::optional<Rigid3d> last_pushed_pose_;
  double last_pushed_time_ = 0.0;  // [s]
  bool busy_ = false;              // optimising after an insertion or RequestRefine
  int pending_refine_ = 0;         // RequestRefine's steps not yet started (queue_mutex_)
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace dypho
