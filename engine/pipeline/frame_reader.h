// The reader thread of `dypho run` (step 1): frames decoded ahead of the
// tracking thread.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/check.h"
#include "common/thread_name.h"
#include "engine/dataset/dataset.h"

namespace dypho {

// Reads frames ahead of the tracking thread; at most `depth` decoded frames wait.
class FrameReader {
 public:
  FrameReader(const Dataset& dataset, std::vector<size_t> indices, int depth)
      : dataset_(dataset), indices_(std::move(indices)), depth_(depth) {
    if (depth_ > 0) thread_ = std::thread([this] { Loop(); });
  }
  ~FrameReader() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  // The k-th frame of `indices` in `frame` (k increasing from call to call;
  // frames may be skipped), or false with the message of
  // the read error (bad input: a truncated image, a wrong size) in `error`.
  // Other errors are rethrown.
  bool Get(size_t k, Frame* frame, std::string* error) {
    if (depth_ == 0) {
      try {
        *frame = dataset_.Load(indices_[k]);
        return true;
      } catch (const InvalidInput& e) {
        *error = e.message();
        return false;
      }
    }
    // Frames before the k-th were skipped (realtime: dropped): their entries go.
    std::unique_lock<std::mutex> lock(mutex_);
    Entry entry;
    do {
      cv_.wait(lock, [&] { return !ready_.empty() || error_; });
      if (ready_.empty() && error_) std::rethrow_exception(error_);
      entry = std::move(ready_.front());
      ready_.pop_front();
      cv_.notify_all();
    } while (entry.position < k);
    DYPHO_CHECK(entry.position == k && entry.index == indices_[k]) << "frame reader out of order";
    cv_.notify_all();
    if (!entry.error.empty()) {
      *error = entry.error;
      return false;
    }
    *frame = std::move(entry.frame);
    return true;
  }

 private:
  void Loop() {
    SetCurrentThreadName("dypho-read");
    for (size_t k = 0; k < indices_.size(); ++k) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [&] { return stop_ || static_cast<int>(ready_.size()) < depth_; });
        if (stop_) return;
      }
      try {
        Entry entry;
        entry.position = k;
        entry.index = indices_[k];
        try {
          entry.frame = dataset_.Load(indices_[k]);
        } catch (const InvalidInput& e) {
          entry.error = e.message();  // this frame is bad; the next may be fine
        }
        std::lock_guard<std::mutex> lock(mutex_);
        ready_.push_back(std::move(entry));
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        error_ = std::current_exception();
        cv_.notify_all();
        return;
      }
      cv_.notify_all();
    }
  }
  const Dataset& dataset_;
  std::vector<size_t> indices_;
  int depth_;
  std::mutex mutex_;
  std::condition_variable cv_;
  struct Entry {
    size_t position = 0;  // in indices_
    size_t index = 0;
    Frame frame;
    std::string error;  // non-empty: the frame could not be read
  };
  std::deque<Entry> ready_;
  std::exception_ptr error_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace dypho
