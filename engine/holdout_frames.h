// The held-back frames of an engine (EngineOptions::holdout_every): every
// `every`-th frame that is not a keyframe, at most `max_frames`, evenly
// spread (when full, every second one is dropped and the spacing doubles).
// They are kept packed (keyframe_store.h: PNG colour, 16-bit depth), and
// both the making of a kept frame (undistortion, depth at the colour time:
// about 1 ms a frame on average at 640x480) and its packing (about 40 ms
// for a 1241x376 stereo frame) run on a thread of the engine's own when
// `threaded` (a SideWorker created with the engine, so it has the mapping
// thread's priority), not on the thread that pushes frames. Which frames are
// kept does not depend on that thread's progress. An error in making or
// packing a frame reaches the caller of Unpacked.
#pragma once

#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <vector>

#include "common/side_worker.h"
#include "engine/map/keyframe_store.h"

namespace dypho {

class HoldoutFrames {
 public:
  HoldoutFrames(int every, int max_frames, bool threaded);
  ~HoldoutFrames();
  HoldoutFrames(const HoldoutFrames&) = delete;
  HoldoutFrames& operator=(const HoldoutFrames&) = delete;

  // A frame that is not a keyframe: whether it is kept (call once per such
  // frame; when true, Add it next).
  bool Due();
  // The kept frame: `make` builds it, on the packing thread when threaded,
  // so it must own what it uses.
  void Add(std::function<KeyframeInput()> make);
  // Waits for the packing; the kept frames, unpacked, oldest first. Throws
  // what making or packing a kept frame threw.
  std::vector<KeyframeInput> Unpacked();

 private:
  struct Slot {
    PackedKeyframe packed;
    std::shared_future<void> done;  // the packing job (ready at once when not threaded)
  };

  const int every_, max_frames_;
  int stride_ = 1;  // keep every every_ * stride_-th frame (Due's thread)
  int since_ = 0;   // frames offered since the last kept one (Due's thread)
  bool due_ = false;  // Due said yes and Add has not come yet (Due's thread)

  std::mutex mutex_;  // guards kept_
  std::vector<std::shared_ptr<Slot>> kept_;
  SideWorker worker_;  // declared last: it finishes its jobs and ends first
};

}  // namespace dypho
