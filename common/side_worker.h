// One helper thread for work handed off and collected later through
// futures: the tracker's image-only work (TrackerPrepareJob) while the
// tracking thread makes the frame's masks, mask overlays, the engine's
// held-back frames. Not threaded (sequential runs), a job runs when it is
// submitted; either way the results are the same, and a job's exception
// reaches whoever gets its future.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

namespace dypho {

class SideWorker {
 public:
  // `thread_name`: shown by top -H (at most 15 characters kept).
  SideWorker(bool threaded, std::string thread_name);
  ~SideWorker();  // runs the jobs still queued, then ends the thread
  SideWorker(const SideWorker&) = delete;
  SideWorker& operator=(const SideWorker&) = delete;

  // `job`'s result, or its exception, arrives through the future.
  template <typename T>
  std::future<T> Submit(std::function<T()> job) {
    auto task = std::make_shared<std::packaged_task<T()>>(std::move(job));
    std::future<T> result = task->get_future();
    Post([task] { (*task)(); });
    return result;
  }

 private:
  void Post(std::function<void()> job);
  void Loop();

  std::string name_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> jobs_;
  bool stop_ = false;
  std::thread thread_;
};

// A future that is waited for when it goes out of scope (its job may use
// buffers of the caller's frame).
template <typename T>
class Awaited {
 public:
  Awaited() = default;
  explicit Awaited(std::future<T> f) : f_(std::move(f)) {}
  Awaited(Awaited&&) noexcept = default;
  Awaited& operator=(Awaited&& other) noexcept {
    Wait();
    f_ = std::move(other.f_);
    return *this;
  }
  ~Awaited() { Wait(); }
  bool valid() const { return f_.valid(); }
  T get() { return f_.get(); }  // rethrows the job's exception

 private:
  void Wait() {
    if (f_.valid()) f_.wait();
  }
  std::future<T> f_;
};

}  // namespace dypho
