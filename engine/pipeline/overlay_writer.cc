#include "engine/pipeline/overlay_writer.h"

#include <algorithm>
#include <utility>

#include "common/thread_name.h"
#include "engine/io/image_io.h"

namespace dypho {

OverlayWriter::OverlayWriter(bool threaded, int max_pending) : max_pending_(std::max(1, max_pending)) {
  if (threaded) worker_ = std::thread([this] { Work(); });
}

OverlayWriter::~OverlayWriter() {
  {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return queue_.empty() && !busy_; });
    stop_ = true;
  }
  cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void OverlayWriter::Draw(const Job& job) {
  const cv::Mat overlay = DrawMaskOverlay(job.rgb, job.masks);
  ImageU8 image(overlay.cols, overlay.rows, overlay.channels());
  overlay.copyTo(cv::Mat(overlay.rows, overlay.cols, overlay.type(), image.data()));
  WriteRgb8(job.path, image);
}

void OverlayWriter::Write(const std::string& path, const cv::Mat& rgb, const MaskResult& masks) {
  Job job;
  job.path = path;
  // What DrawMaskOverlay reads, owned.
  job.rgb = rgb.clone();
  job.masks.mask = masks.mask.clone();
  job.masks.detections = masks.detections;
  job.masks.features = masks.features;
  if (!worker_.joinable()) {
    Draw(job);
    return;
  }
  {
    std::unique_lock<std::mutex> lock(mutex_);
    ThrowIfFailed();
    cv_.wait(lock, [this] { return static_cast<int>(queue_.size()) < max_pending_; });
    queue_.push_back(std::move(job));
  }
  cv_.notify_all();
}

void OverlayWriter::Finish() {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [this] { return queue_.empty() && !busy_; });
  ThrowIfFailed();
}

void OverlayWriter::ThrowIfFailed() {
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void OverlayWriter::Work() {
  SetCurrentThreadName("dypho-overlay");
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
    if (queue_.empty()) return;  // stop_
    Job job = std::move(queue_.front());
    queue_.pop_front();
    busy_ = true;
    lock.unlock();
    try {
      Draw(job);
    } catch (...) {
      lock.lock();
      if (!error_) error_ = std::current_exception();
      lock.unlock();
    }
    lock.lock();
    busy_ = false;
    cv_.notify_all();
  }
}

}  // namespace dypho
