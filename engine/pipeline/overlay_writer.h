// The mask overlays of a run (overlays/*.jpg), drawn and written on a
// thread of their own in threaded runs: drawing and encoding one took about
// 3.5 ms of the tracking thread (one every overlay_every frames). At most
// `max_pending` wait; beyond that Write waits for room. An error of the
// worker (e.g. a full disk) is thrown by the next Write or by Finish.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <string>
#include <thread>

#include <opencv2/core.hpp>

#include "masking/dynamic_masker.h"

namespace dypho {

class OverlayWriter {
 public:
  explicit OverlayWriter(bool threaded, int max_pending = 4);
  ~OverlayWriter();  // waits for the pending overlays (errors dropped: call Finish to see them)
  OverlayWriter(const OverlayWriter&) = delete;
  OverlayWriter& operator=(const OverlayWriter&) = delete;

  // Draws DrawMaskOverlay(rgb, masks) into `path` (JPEG by its extension).
  // Copies what it needs: the caller may change or free rgb and masks.
  void Write(const std::string& path, const cv::Mat& rgb, const MaskResult& masks);
  // Waits until every overlay is written; throws the first error.
  void Finish();

 private:
  struct Job {
    std::string path;
    cv::Mat rgb;
    MaskResult masks;
  };
  static void Draw(const Job& job);
  void Work();
  void ThrowIfFailed();  // caller holds mutex_

  const int max_pending_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Job> queue_;
  bool busy_ = false, stop_ = false;
  std::exception_ptr error_;
  std::thread worker_;
};

}  // namespace dypho
