#include "engine/holdout_frames.h"

#include <utility>

#include "common/check.h"

namespace dypho {

HoldoutFrames::HoldoutFrames(int every, int max_frames, bool threaded)
    : every_(every), max_frames_(max_frames), worker_(threaded && every > 0, "dypho-holdout") {}

// The worker (declared last) finishes the queued jobs first; they hold their slots.
HoldoutFrames::~HoldoutFrames() = default;

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
  // A frame dropped by the thinning below is made and packed all the same (and then freed).
  slot->done = worker_.Submit<void>([slot, make = std::move(make)] { slot->packed = PackKeyframe(make()); }).share();
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
}

std::vector<KeyframeInput> HoldoutFrames::Unpacked() {
  std::vector<std::shared_ptr<Slot>> kept;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    kept = kept_;
  }
  std::vector<KeyframeInput> out;
  for (const auto& slot : kept) {
    slot->done.get();  // rethrows the job's error
    out.push_back(UnpackKeyframe(slot->packed));
  }
  return out;
}

}  // namespace dypho
