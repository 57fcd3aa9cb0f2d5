#include "engine/keyframe_masks.h"

#include <chrono>
#include <utility>

#include "common/check.h"

namespace dypho {

KeyframeMasks::KeyframeMasks(const EngineOptions& options, const Undistorter& undistort, int max_pending)
    : options_(options), undistort_(undistort), max_pending_(max_pending) {
  DYPHO_CHECK(max_pending >= 0) << "KeyframeMasks: max_pending must be >= 0";
}

ImageU8 KeyframeMasks::Ask(PushedFrame frame, bool on_push) {
  const auto start = std::chrono::steady_clock::now();
  std::optional<ImageU8> mask = AskKeyframeMask(options_, std::move(frame));
  ImageU8 excluded;
  if (mask) excluded = undistort_.ExcludedPixels(*mask);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::lock_guard<std::mutex> lock(mutex_);
  ++counts_.asked;
  if (on_push) ++counts_.on_push;
  counts_.ms += ms;
  return excluded;
}

void KeyframeMasks::Add(PushedFrame frame) {
  if (!options_.keyframe_mask) return;
  frame.right = ImageU8();  // the hook gets the left image only
  double oldest_time = 0.0;
  PushedFrame oldest;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const double t = frame.timestamp;
    pending_[t].frame = std::move(frame);
    int waiting = 0;
    for (const auto& [timestamp, p] : pending_) waiting += p.frame.has_value();
    if (waiting <= max_pending_) return;
    for (auto& [timestamp, p] : pending_) {
      if (!p.frame) continue;
      oldest_time = timestamp;
      oldest = std::move(*p.frame);
      p.frame.reset();
      p.asking = true;
      break;
    }
  }
  // Too many whole frames waiting: the oldest is answered here, outside the
  // lock (Resolve of that keyframe waits for it).
  ImageU8 excluded = Ask(std::move(oldest), true);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Pending& p = pending_[oldest_time];
    p.excluded = std::move(excluded);
    p.asking = false;
  }
  answered_.notify_all();
}

void KeyframeMasks::Resolve(KeyframeInput* input) {
  if (!options_.keyframe_mask) return;
  std::optional<PushedFrame> frame;
  ImageU8 excluded;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    auto it = pending_.find(input->timestamp);
    if (it == pending_.end()) return;
    answered_.wait(lock, [&] { return !it->second.asking; });
    frame = std::move(it->second.frame);
    excluded = std::move(it->second.excluded);
    pending_.erase(it);
  }
  if (frame) excluded = Ask(std::move(*frame), false);
  if (excluded.empty()) return;
  if (input->dynamic_mask.empty()) {
    input->dynamic_mask = std::move(excluded);
    return;
  }
  DYPHO_CHECK(excluded.size() == input->dynamic_mask.size()) << "KeyframeMasks: mask size mismatch";
  for (size_t i = 0; i < excluded.size(); ++i)
    if (excluded.data()[i]) input->dynamic_mask.data()[i] = 255;
}

KeyframeMaskCounts KeyframeMasks::counts() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counts_;
}

}  // namespace dypho
