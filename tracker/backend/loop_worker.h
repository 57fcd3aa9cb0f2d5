// The back-end thread of loop closing (tracker.loops.threaded): the tracker
// hands it a snapshot of the sparse map and of the place database after
// each keyframe (LoopJob); the worker runs the detection (BoW query,
// consistency, geometric verification) and, for a loop, the closure (pose
// graph, global BA) on that snapshot, never on the live map, and returns
// the outcome: for every keyframe of the snapshot how the closure moved it
// (LoopOutcome::world_corrections), the corrected point positions and the
// point pairs to fuse. The tracker applies it to its live map at a later
// frame (orb_tracker_loops.cc: keyframes and points made since the
// snapshot move as the closing keyframe moved).
//
// Jobs are processed one at a time in the order submitted (the detector's
// temporal consistency needs every keyframe's query, in order); outcomes
// are taken in the same order. A job whose processing throws is taken as
// that exception, rethrown by Take/WaitAndTake (threaded) or by Submit
// (synchronous: nothing is kept of it), so the worker never waits forever
// for an outcome that cannot come.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "common/rigid3.h"
#include "tracker/backend/bow_database.h"
#include "tracker/backend/loop_correction.h"
#include "tracker/backend/loop_detection.h"
#include "tracker/backend/sparse_map.h"

namespace dypho {

struct LoopJob {
  long frame = -1;    // tracker frame counter at the snapshot
  int keyframe = -1;  // the new keyframe to query
  bool reset = false; // too few keyframes: no query, the detector forgets its groups (no snapshot)
  SparseMap map;      // snapshot (the closure changes it)
  BowDatabase bow;    // snapshot
};

struct LoopOutcome {
  long frame = -1;
  int keyframe = -1;
  bool queried = false;               // a detection ran (not a reset job)
  LoopDetectionResult detection;      // its result (the loop when found)
  double query_ms = 0.0;              // [ms] detection time
  bool closed = false;                // the loop was closed on the snapshot
  LoopCorrection correction;          // when closed
  double global_ba_ms = 0.0;          // [ms]
  int erased = 0;                     // global-BA outlier observations erased (on the snapshot when threaded)
  // When closed, per snapshot keyframe: new world_from_cam * old
  // world_from_cam^-1 (how the closure and the global BA moved it).
  std::vector<Rigid3d> world_corrections;
  // When closed, per snapshot point: its position before the closure and
  // after it (and after the global BA).
  std::vector<Eigen::Vector3d> points_before, points_after;
};

class LoopWorker {
 public:
  using ProcessFn = std::function<LoopOutcome(LoopJob)>;
  // synchronous: no thread; Submit processes the job at once on the caller's
  // thread and keeps the outcome until it is taken.
  explicit LoopWorker(ProcessFn process, bool synchronous = false);
  ~LoopWorker();  // finishes the job in flight, drops the queued ones, joins
  LoopWorker(const LoopWorker&) = delete;
  LoopWorker& operator=(const LoopWorker&) = delete;

  void Submit(LoopJob job);
  // Jobs submitted and not yet taken (queued, running or done).
  int InFlight();
  // The frame of the oldest job not yet taken; -1 when none.
  long OldestFrame();
  // The oldest outcome when it is ready (non-blocking).
  std::optional<LoopOutcome> Take();
  // Blocks until the oldest job is done, then takes it (nullopt when none).
  std::optional<LoopOutcome> WaitAndTake();

 private:
  void Loop();

  ProcessFn process_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<LoopJob> pending_;
  std::deque<long> frames_;        // of every job not yet taken, oldest first
  struct Done {
    LoopOutcome outcome;
    std::exception_ptr error;  // processing threw: rethrown when taken
  };
  LoopOutcome TakeDone();  // the oldest done job (mutex_ held), rethrowing its error
  std::deque<Done> done_;
  bool running_ = false;
  bool stop_ = false;
  bool synchronous_ = false;
  std::thread thread_;
};

}  // namespace dypho
