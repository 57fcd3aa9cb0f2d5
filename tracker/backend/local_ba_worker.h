// The back-end thread of the local bundle adjustment: the tracker hands it a
// snapshot of the local window (LocalBaProblem) after a keyframe and picks up
// the solution at a later frame; the map itself is only touched on the
// tracking thread (BuildLocalBaProblem before, ApplyLocalBa after). One
// problem at a time: a keyframe that arrives while a solve runs gets no BA of
// its own (the next keyframe's window covers it).
//
// Synchronous (no thread): Submit solves at once on the caller's thread and
// keeps the solution until it is taken, so that a sequential run applies it
// at the same frame a threaded run with a fixed lag does.
#pragma once

#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>

#include "tracker/backend/local_ba.h"

namespace dypho {

class LocalBaWorker {
 public:
  using SolveFn = std::function<LocalBaSolution(LocalBaProblem)>;
  explicit LocalBaWorker(SolveFn solve, bool synchronous = false);
  ~LocalBaWorker();  // finishes the solve in flight, then joins (threaded)
  LocalBaWorker(const LocalBaWorker&) = delete;
  LocalBaWorker& operator=(const LocalBaWorker&) = delete;

  // Whether a problem is queued, being solved, or solved and not yet taken.
  bool Busy();
  // Starts solving `problem`; false (and nothing done) when busy.
  bool Submit(LocalBaProblem problem);
  // The solution when one is ready (non-blocking).
  std::optional<LocalBaSolution> Take();
  // Blocks until the problem in flight (if any) is solved, then takes it.
  std::optional<LocalBaSolution> WaitAndTake();

 private:
  void Loop();

  SolveFn solve_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<LocalBaProblem> pending_;
  std::optional<LocalBaSolution> done_;
  bool running_ = false;
  bool stop_ = false;
  bool synchronous_ = false;
  std::thread thread_;
};

}  // namespace dypho
