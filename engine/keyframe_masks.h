// The keyframe-mask hook (EngineOptions::keyframe_mask) off the pushing
// thread. Asking a detector about a keyframe takes as long as the detector
// (YOLOX-nano: 40-90 ms on this machine's cores), and a keyframe's mask only
// matters once the keyframe is mapped; so the engine keeps the keyframe's
// frame as pushed here and the mapping thread asks the hook just before it
// maps the keyframe (Resolve). The answer depends only on the frame, never
// on when it is asked, so the map is the same as when the pushing thread
// asked. Memory is bounded: when more than `max_pending` keyframes wait with
// their whole frame, the pushing thread answers the oldest one at once and
// keeps only its mask. Internal to the engine library; thread-safe.
#pragma once

#include <condition_variable>
#include <map>
#include <mutex>
#include <optional>

#include "common/image.h"
#include "engine/api.h"
#include "engine/api_frames.h"
#include "engine/map/mapper.h"
#include "engine/map/undistort.h"

namespace dypho {

struct KeyframeMaskCounts {
  int asked = 0;           // hook calls so far
  int on_push = 0;         // of them, made on the pushing thread (more than max_pending waiting)
  double ms = 0.0;         // [ms] time in the hook and the undistortion of its answer, in total
};

class KeyframeMasks {
 public:
  // `options.keyframe_mask` may be empty: then Add and Resolve do nothing.
  KeyframeMasks(const EngineOptions& options, const Undistorter& undistort, int max_pending);

  // The pushing thread: the keyframe made from `frame` (its timestamp is
  // the keyframe's) will need the hook's answer.
  void Add(PushedFrame frame);
  // Before mapping the keyframe `input` (any thread): the hook's answer for
  // it joins input->dynamic_mask (undistorted like it). Keyframes never
  // added are left as they are.
  void Resolve(KeyframeInput* input);
  KeyframeMaskCounts counts() const;

 private:
  struct Pending {
    std::optional<PushedFrame> frame;  // still to ask about
    bool asking = false;               // the pushing thread is asking about it now
    ImageU8 excluded;                  // the answer, undistorted (empty: none or not yet)
  };
  // The hook's answer for `frame` as excluded pixels of the pinhole image
  // (empty when the hook adds nothing).
  ImageU8 Ask(PushedFrame frame, bool on_push);

  const EngineOptions& options_;
  const Undistorter& undistort_;
  const int max_pending_;
  mutable std::mutex mutex_;
  std::condition_variable answered_;
  std::map<double, Pending> pending_;  // by keyframe timestamp
  KeyframeMaskCounts counts_;
};

}  // namespace dypho
