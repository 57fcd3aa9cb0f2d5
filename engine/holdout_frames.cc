#include "engine/holdout_frames.h"

#include <utility>

#include "common/check.h"
#include "common/thread_name.h"

namespace dypho {

HoldoutFrames::HoldoutFrames(int every, int max_frames, bool threaded) : every_(every), max_frames_(max_frames) {
  if (threaded && every > 0) worker_ = std::thread([this] { Work(); });
}

HoldoutFrames::~HoldoutFrames() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

bool HoldoutFrames::Due() {
  DYPHO_CHECK(!due_) << "HoldoutFrames::Due: the last due frame was not added";
  if (every_ <= 0 || ++since_ < every_ * stride_) return false;
  since_ = 0;
  due_ = true;
  return true;
}

void HoldoutFrames::Add(std::function<KeyframeInput()> make) {
  DYPHO_CHECK(due_) << "HoldoutFrames::Add without a due frame";
  due_ = false;
  auto slot = std::make_shared<Slot>();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    kept_.push_back(slot);
    if (static_cast<int>(kept_.size()) > max_frames_) {
      std::vector<std::shared_ptr<Slot>> thinned;
      for (size_t i = 0; i < kept_.size(); i += 2) thinned.push_back(std::move(kept_[i]));
      kept_ = std::move(thinned);
      stride_ *= 2;
    }
  }
  if (!worker_.joinable()) {
    slot->packed = PackKeyframe(make());
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.emplace_back(std::move(slot), std::move(make));
  }
  cv_.notify_all();
}

void HoldoutFrames::Work() {
  SetCurrentThreadName("dypho-holdout");
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
    if (queue_.empty()) return;  // stop_
    auto job = std::move(queue_.front());
    queue_.pop_front();
    busy_ = true;
    lock.unlock();
    // A frame dropped by the thinning meanwhile is made and packed all the same (and then freed).
    job.first->packed = PackKeyframe(job.second());
    lock.lock();
    busy_ = false;
    cv_.notify_all();
  }
}

std::vector<KeyframeInput> HoldoutFrames::Unpacked() {
  std::vector<std::shared_ptr<Slot>> kept;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return queue_.empty() && !busy_; });
    kept = kept_;
  }
  std::vector<KeyframeInput> out;
  for (const auto& slot : kept) out.push_back(UnpackKeyframe(slot->packed));
  return out;
}

}  // namespace dypho
