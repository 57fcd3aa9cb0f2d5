#include "common/side_worker.h"

#include "common/thread_name.h"

namespace dypho {

SideWorker::SideWorker(bool threaded, std::string thread_name) : name_(std::move(thread_name)) {
  if (threaded) thread_ = std::thread([this] { Loop(); });
}

SideWorker::~SideWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void SideWorker::Post(std::function<void()> job) {
  if (!thread_.joinable()) {
    job();  // packaged_task: an exception goes to the future
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    jobs_.push_back(std::move(job));
  }
  cv_.notify_one();
}

void SideWorker::Loop() {
  SetCurrentThreadName(name_.c_str());
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    cv_.wait(lock, [&] { return stop_ || !jobs_.empty(); });
    if (jobs_.empty()) return;  // stop_ and nothing left
    std::function<void()> job = std::move(jobs_.front());
    jobs_.pop_front();
    lock.unlock();
    job();
    lock.lock();
  }
}

}  // namespace dypho
