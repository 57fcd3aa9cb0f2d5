// The mask overlays of a run (overlays/*.jpg), drawn and written on a
// helper thread (side_worker.h) in threaded runs: drawing and encoding one
// took about 3.5 ms of the tracking thread (one every overlay_every frames).
// At most `max_pending` wait; beyond that Write waits for the oldest. An
// error of the worker (e.g. a full disk) is thrown by a later Write or by
// Finish.
#pragma once

#include <deque>
#include <future>
#include <string>

#include <opencv2/core.hpp>

#include "common/side_worker.h"
#include "masking/dynamic_masker.h"

namespace dypho {

class OverlayWriter {
 public:
  explicit OverlayWriter(bool threaded, int max_pending = 4);
  ~OverlayWriter();  // waits for the pending overlays (errors dropped: call Finish to see them)
  OverlayWriter(const OverlayWriter&) = delete;
  OverlayWriter& operator=(const OverlayWriter&) = delete;

  // Draws DrawMaskOverlay(rgb, masks) into `path` (JPEG by its extension).
  // The caller may change or free rgb and masks after the call.
  void Write(const std::string& path, const cv::Mat& rgb, const MaskResult& masks);
  // Waits until every overlay is written; throws the first error.
  void Finish();

 private:
  const bool threaded_;
  const size_t max_pending_;
  std::deque<std::future<void>> pending_;  // oldest first
  SideWorker worker_;                      // last: its thread ends before pending_ goes
};

}  // namespace dypho
