#include "tracker/backend/loop_worker.h"

#include <utility>

#include "common/thread_name.h"

namespace dypho {

LoopWorker::LoopWorker(ProcessFn process, bool synchronous) : process_(std::move(process)), synchronous_(synchronous) {
  if (!synchronous_) thread_ = std::thread([this] { Loop(); });
}

LoopWorker::~LoopWorker() {
  if (synchronous_) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    pending_.clear();
  }
  cv_.notify_all();
  thread_.join();
}

void LoopWorker::Submit(LoopJob job) {
  if (synchronous_) {
    const long frame = job.frame;
    LoopOutcome outcome = process_(std::move(job));  // a throw leaves nothing listed
    frames_.push_back(frame);
    done_.push_back({std::move(outcome), nullptr});
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frames_.push_back(job.frame);
    pending_.push_back(std::move(job));
  }
  cv_.notify_all();
}

int LoopWorker::InFlight() {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(frames_.size());
}

long LoopWorker::OldestFrame() {
  std::lock_guard<std::mutex> lock(mutex_);
  return frames_.empty() ? -1 : frames_.front();
}

LoopOutcome LoopWorker::TakeDone() {
  Done d = std::move(done_.front());
  done_.pop_front();
  frames_.pop_front();
  if (d.error) std::rethrow_exception(d.error);
  return std::move(d.outcome);
}

std::optional<LoopOutcome> LoopWorker::Take() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (done_.empty()) return std::nullopt;
  return TakeDone();
}

std::optional<LoopOutcome> LoopWorker::WaitAndTake() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (frames_.empty()) return std::nullopt;
  cv_.wait(lock, [this] { return !done_.empty(); });
  return TakeDone();
}

void LoopWorker::Loop() {
  SetCurrentThreadName("dypho-loop");
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    cv_.wait(lock, [this] { return stop_ || !pending_.empty(); });
    if (pending_.empty()) return;  // stop requested, nothing queued
    LoopJob job = std::move(pending_.front());
    pending_.pop_front();
    running_ = true;
    lock.unlock();
    Done done;
    try {
      done.outcome = process_(std::move(job));
    } catch (...) {
      done.error = std::current_exception();
    }
    lock.lock();
    running_ = false;
    done_.push_back(std::move(done));
    cv_.notify_all();
    if (stop_) return;
  }
}

}  // namespace dypho
