#include "tracker/backend/local_ba_worker.h"

#include <utility>

#include "common/thread_name.h"

namespace dypho {

LocalBaWorker::LocalBaWorker(SolveFn solve, bool synchronous) : solve_(std::move(solve)), synchronous_(synchronous) {
  if (!synchronous_) thread_ = std::thread([this] { Loop(); });
}

LocalBaWorker::~LocalBaWorker() {
  if (synchronous_) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

bool LocalBaWorker::Busy() {
  std::lock_guard<std::mutex> lock(mutex_);
  return pending_.has_value() || running_ || done_.has_value();
}

bool LocalBaWorker::Submit(LocalBaProblem problem) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_.has_value() || running_ || done_.has_value()) return false;
    if (synchronous_) {
      done_ = solve_(std::move(problem));
      return true;
    }
    pending_ = std::move(problem);
  }
  cv_.notify_all();
  return true;
}

std::optional<LocalBaSolution> LocalBaWorker::Take() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<LocalBaSolution> out = std::move(done_);
  done_.reset();
  return out;
}

std::optional<LocalBaSolution> LocalBaWorker::WaitAndTake() {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [this] { return !pending_.has_value() && !running_; });
  std::optional<LocalBaSolution> out = std::move(done_);
  done_.reset();
  return out;
}

void LocalBaWorker::Loop() {
  SetCurrentThreadName("dypho-localba");
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    cv_.wait(lock, [this] { return stop_ || pending_.has_value(); });
    if (!pending_.has_value()) return;  // stop requested, nothing queued
    LocalBaProblem problem = std::move(*pending_);
    pending_.reset();
    running_ = true;
    lock.unlock();
    LocalBaSolution solution = solve_(std::move(problem));
    lock.lock();
    running_ = false;
    done_ = std::move(solution);
    cv_.notify_all();
    if (stop_) return;
  }
}

}  // namespace dypho
