// Running a slow segmenter (YOLOX-nano takes about 75 ms a frame on one CPU
// core) on some frames only, or in its own thread, and carrying its masks to
// the frames in between along the optical flow (WarpMaskByFlow).
//
// Synchronous mode (threaded = false): the segmenter runs on frame 0, then
// whenever `interval` frames have passed since its last run, or the caller
// forces a run (e.g. on a keyframe). Other frames get the previous frame's
// mask warped by the current frame's backward flow.
//
// Threaded mode: the segmenter runs in a worker thread on a copy of the
// frame; a new frame is handed to it when it is idle and `interval` frames
// have passed since the last hand-over (or a run is forced). Each frame takes
// the newest finished result, carried from its frame to the current one
// through the stored flows of the frames in between (at most
// max_carry_frames; older results are dropped), otherwise the previous mask
// warped by the current flow. The first frame waits for its result, so that
// the sequence starts with a mask.
//
// Fixed lag (threaded, fixed_lag = n > 0): results independent of timing.
// The segmenter is handed frames 0, p, 2p, ... (p = max(interval, n); a
// forced run when no job is in flight), and the result of frame j is
// taken at frame j + n exactly: the frame waits for it when it is late,
// and a result that is early waits unused. Masks are then n..p+n-1 frames
// old, and the same on a fast or a slow machine (MaskLagForAge chooses n
// for a largest age). Not threaded with fixed_lag = n > 0: the same
// schedule with the segmenter run on the caller's thread at hand-over, so
// that a sequential run gets the threaded run's masks.
//
// Look-ahead (look_ahead = a > 0; frames read from a recording): the
// detector frames are 0, p, 2p, ... (p = interval) and each gets its own,
// fresh mask. At frame j the caller offers frame j + a (Next's `ahead`: a
// loader run on the worker thread, so decoding it costs the caller
// nothing); when j + a is a detector frame the worker segments it, and
// frame j + a takes that result, waiting for it when late. Masks are then
// 0..p-1 frames old, the same on any machine. A result whose frame name
// differs from the frame that takes it (a frame in between could not be
// read) is dropped and the frame segmented at once; so is every detector
// frame without an offered result (the first a frames). Not threaded: each
// detector frame is segmented when it comes, which gives the same masks.
// `force_run` is ignored.
//
// Without a flow (first frame, or none given) a carried mask is used as it is.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "masking/flow_motion.h"
#include "masking/segmenter.h"

namespace dypho {

struct SegmenterScheduleOptions {
  int interval = 1;           // run the segmenter every `interval` frames (1 = every frame), 1..1000
  bool threaded = false;      // run it in its own thread; frames use the newest result carried by the flow
  int max_carry_frames = 30;  // results older than this many frames are dropped [frames], 1..1000
  // The result of frame j is used at frame j + fixed_lag exactly, waiting
  // for it when late (threaded; not threaded: run at j, kept until j +
  // fixed_lag); 0 = threaded: the newest result whenever it arrives (depends
  // on timing), not threaded: used at once [frames], 0..max_carry_frames.
  int fixed_lag = 0;
  // Frames the caller offers ahead (see above; 0 = off); needs fixed_lag 0 [frames], 0..max_carry_frames.
  int look_ahead = 0;
  double debug_delay_ms = 0.0;  // test hook: the segmenter thread sleeps this long before each run [ms], >= 0

  bool IsValid(std::string* error) const;
};

struct ScheduledSegmentation {
  cv::Mat mask;                       // CV_8UC1, image size, 255 = dynamic
  std::vector<Detection> detections;  // of the frame the mask came from (positions not carried)
  long source_frame = -1;             // frame the segmenter ran on (-1 = none yet)
  bool fresh = false;                 // the segmenter ran on this frame (source_frame == this frame)
};

// The largest fixed_lag whose masks are at most `max_age` frames old with
// the segmenter run every `interval` frames (ages n..max(interval, n)+n-1);
// 0 when max_age < interval (no lag fits).
int MaskLagForAge(int max_age, int interval);

// A frame's segmenter input, loaded on demand (SegmenterScheduleOptions::look_ahead).
using AheadLoader = std::function<std::optional<SegmenterInput>()>;

class AsyncSegmenter {
 public:
  // Throws InvalidInput naming the field for invalid options.
  AsyncSegmenter(std::unique_ptr<Segmenter> segmenter, const SegmenterScheduleOptions& options);
  // Waits for a running job.
  ~AsyncSegmenter();
  AsyncSegmenter(const AsyncSegmenter&) = delete;
  AsyncSegmenter& operator=(const AsyncSegmenter&) = delete;

  // The semantic mask of the next frame. `flow`: the backward flow from this
  // frame to the previous one given to Next (empty for the first frame).
  // `force_run`: run the segmenter on this frame (e.g. a keyframe). An
  // exception thrown by the segmenter in the worker thread is rethrown here.
  // `ahead` (look_ahead > 0): the input of the frame look_ahead frames after
  // this one, loaded when called (on the worker thread; nullopt when there
  // is none or it cannot be read); may be empty.
  ScheduledSegmentation Next(const SegmenterInput& input, const BackwardFlow& flow, bool force_run = false,
                             const AheadLoader& ahead = AheadLoader());
  // Waits for the worker, forgets masks and flows; frame numbers restart at 0.
  void Reset();
  // Frames passed to Next since construction or Reset.
  long frames() const;
  // Fixed lag: frames that waited for a late result, and their time waiting [ms].
  long waits() const;
  double wait_ms() const;
  const Segmenter& segmenter() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho
