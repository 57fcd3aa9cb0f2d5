#include "masking/async_segmenter.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <sstream>
#include <thread>
#include <utility>

#include "common/check.h"
#include "common/thread_name.h"

namespace dypho {

bool SegmenterScheduleOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (interval < 1 || interval > 1000)
    msg << "interval must be in 1..1000 (got " << interval << ")";
  else if (max_carry_frames < 1 || max_carry_frames > 1000)
    msg << "max_carry_frames must be in 1..1000 (got " << max_carry_frames << ")";
  else if (fixed_lag < 0 || fixed_lag > max_carry_frames)
    msg << "fixed_lag must be in 0..max_carry_frames (" << max_carry_frames << ") (got " << fixed_lag << ")";
  else if (look_ahead < 0 || look_ahead > interval)
    msg << "look_ahead must be in 0..interval (" << interval << ") (got " << look_ahead << ")";
  else if (look_ahead > 0 && fixed_lag > 0)
    msg << "look_ahead and fixed_lag exclude each other (got " << look_ahead << " and " << fixed_lag << ")";
  else if (!(debug_delay_ms >= 0.0 && debug_delay_ms <= 60000.0))
    msg << "debug_delay_ms must be in 0..60000 (got " << debug_delay_ms << ")";
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

int MaskLagForAge(int max_age, int interval) {
  // Ages n..max(interval, n)+n-1: n <= interval needs interval + n - 1 <=
  // max_age; n > interval needs 2n - 1 <= max_age.
  int best = 0;
  for (int n = 1; n <= max_age; ++n)
    if (std::max(interval, n) + n - 1 <= max_age) best = n;
  return best;
}

struct AsyncSegmenter::Impl {
  std::unique_ptr<Segmenter> segmenter;
  SegmenterScheduleOptions options;

  // Caller-side state.
  long frame = -1;     // last frame passed to Next
  long last_run = -1;  // last frame the segmenter ran on or was handed
  cv::Mat mask;        // mask of `frame`
  std::vector<Detection> detections;
  long source_frame = -1;
  std::deque<std::pair<long, BackwardFlow>> flows;  // (f, backward flow from f to f - 1)
  long in_flight = -1;  // fixed lag: the frame of the job handed and not taken yet (-1 = none)
  long waits = 0;       // fixed lag: frames that waited for a late result
  double wait_ms = 0.0;

  // Worker state, guarded by `mutex`.
  std::thread worker;
  std::mutex mutex;
  std::condition_variable wake;
  bool stop = false;
  bool job_pending = false;
  bool busy = false;
  SegmenterInput job;
  AheadLoader job_loader;  // look-ahead: the job's input is loaded on the worker
  long job_frame = -1;
  bool result_ready = false;
  Segmentation result;
  long result_frame = -1;
  std::string result_name;     // the input's name
  bool result_loaded = true;   // false: the look-ahead loader had no frame
  long ahead_frame = -1;       // look-ahead: the frame of the job handed and not taken yet (caller side)
  std::exception_ptr error;

  void WorkerLoop() {
    SetCurrentThreadName("dypho-detect");
    std::unique_lock<std::mutex> lock(mutex);
    while (true) {
      wake.wait(lock, [&] { return stop || job_pending; });
      if (stop) return;
      SegmenterInput input = std::move(job);
      AheadLoader loader = std::move(job_loader);
      job_loader = nullptr;
      const long input_frame = job_frame;
      job_pending = false;
      busy = true;
      lock.unlock();
      if (options.debug_delay_ms > 0)
        std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(options.debug_delay_ms));
      Segmentation out;
      bool loaded = true;
      std::exception_ptr failure;
      try {
        if (loader) {
          std::optional<SegmenterInput> ahead = loader();
          loaded = ahead.has_value();
          if (loaded) input = std::move(*ahead);
        }
        if (loaded) out = segmenter->Segment(input);
      } catch (...) {
        failure = std::current_exception();
      }
      lock.lock();
      busy = false;
      if (failure) {
        error = failure;
      } else {
        result = std::move(out);
        result_frame = input_frame;
        result_name = input.name;
        result_loaded = loaded;
        result_ready = true;
      }
      wake.notify_all();
    }
  }

  // `m` (a mask of frame `from`) carried to frame `to` through the stored flows.
  cv::Mat Carry(cv::Mat m, long from, long to) const {
    for (long f = from + 1; f <= to; ++f) {
      for (const auto& [frame_index, flow] : flows) {
        if (frame_index != f) continue;
        if (flow.image_size == m.size()) m = WarpMaskByFlow(m, flow);
        break;
      }
    }
    return m;
  }

  // Rethrows (once) an exception of the worker's segmenter (call with `mutex` held).
  void RethrowWorkerError() {
    if (!error) return;
    std::exception_ptr e = error;
    error = nullptr;
    std::rethrow_exception(e);
  }

  // Look-ahead schedule (SegmenterScheduleOptions::look_ahead) for frame
  // `frame`; the carried mask is already warped to it.
  void NextAhead(const SegmenterInput& input, const AheadLoader& ahead) {
    const int a = options.look_ahead, p = options.interval;
    std::unique_lock<std::mutex> lock(mutex);
    RethrowWorkerError();
    if (frame % p == 0) {
      bool taken = false;
      if (ahead_frame == frame) {
        if (!result_ready) {
          const auto start = std::chrono::steady_clock::now();
          wake.wait(lock, [&] { return result_ready || error; });
          ++waits;
          wait_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
          RethrowWorkerError();
        }
        result_ready = false;
        ahead_frame = -1;
        if (result_loaded && result_name == input.name) {
          mask = std::move(result.mask);
          detections = std::move(result.detections);
          taken = true;
        }
      }
      if (!taken) {
        // Nothing offered for this frame (or not this frame's): segmented
        // now, on this thread (the worker is idle: no job is in flight).
        wake.wait(lock, [&] { return !busy && !job_pending; });
        Segmentation seg = segmenter->Segment(input);
        mask = seg.mask;
        detections = std::move(seg.detections);
      }
      source_frame = frame;
      last_run = frame;
    }
    if (options.threaded && ahead && (frame + a) % p == 0 && ahead_frame < 0) {
      job = SegmenterInput();
      job_loader = ahead;
      job_frame = frame + a;
      job_pending = true;
      ahead_frame = frame + a;
      wake.notify_all();
    }
  }

  // Takes a finished result (call with `mutex` held).
  void TakeResult() {
    result_ready = false;
    if (frame - result_frame > options.max_carry_frames) return;
    mask = Carry(result.mask, result_frame, frame);
    detections = std::move(result.detections);
    source_frame = result_frame;
  }
};

AsyncSegmenter::AsyncSegmenter(std::unique_ptr<Segmenter> segmenter, const SegmenterScheduleOptions& options)
    : impl_(std::make_unique<Impl>()) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "SegmenterScheduleOptions." << error;
  DYPHO_CHECK_INPUT(segmenter != nullptr) << "AsyncSegmenter needs a segmenter";
  impl_->segmenter = std::move(segmenter);
  impl_->options = options;
  if (options.threaded) impl_->worker = std::thread([this] { impl_->WorkerLoop(); });
}

AsyncSegmenter::~AsyncSegmenter() {
  if (impl_->worker.joinable()) {
    {
      std::lock_guard<std::mutex> lock(impl_->mutex);
      impl_->stop = true;
    }
    impl_->wake.notify_all();
    impl_->worker.join();
  }
}

long AsyncSegmenter::frames() const { return impl_->frame + 1; }

long AsyncSegmenter::waits() const { return impl_->waits; }

double AsyncSegmenter::wait_ms() const { return impl_->wait_ms; }

const Segmenter& AsyncSegmenter::segmenter() const { return *impl_->segmenter; }

void AsyncSegmenter::Reset() {
  Impl& s = *impl_;
  {
    std::unique_lock<std::mutex> lock(s.mutex);
    s.wake.wait(lock, [&] { return !s.busy && !s.job_pending; });
    s.result_ready = false;
    s.error = nullptr;
  }
  s.frame = -1;
  s.last_run = -1;
  s.mask.release();
  s.detections.clear();
  s.source_frame = -1;
  s.flows.clear();
  s.in_flight = -1;
  s.ahead_frame = -1;
}

ScheduledSegmentation AsyncSegmenter::Next(const SegmenterInput& input, const BackwardFlow& flow, bool force_run,
                                           const AheadLoader& ahead) {
  CheckSegmenterInput(input);
  Impl& s = *impl_;
  ++s.frame;
  const bool usable_flow = !flow.empty() && flow.image_size == input.rgb.size();
  if (usable_flow) s.flows.emplace_back(s.frame, flow);
  while (!s.flows.empty() && s.flows.front().first <= s.frame - s.options.max_carry_frames) s.flows.pop_front();
  // The previous mask carried to this frame.
  if (!s.mask.empty() && s.mask.size() != input.rgb.size()) s.mask.release();
  if (!s.mask.empty() && usable_flow) s.mask = WarpMaskByFlow(s.mask, flow);
  const bool due = s.last_run < 0 || s.frame - s.last_run >= s.options.interval || force_run;

  if (s.options.look_ahead > 0) {
    s.NextAhead(input, ahead);
  } else if (!s.options.threaded && s.options.fixed_lag == 0) {
    if (due) {
      Segmentation seg = s.segmenter->Segment(input);
      s.mask = seg.mask;
      s.detections = std::move(seg.detections);
      s.source_frame = s.frame;
      s.last_run = s.frame;
    }
  } else {
    std::unique_lock<std::mutex> lock(s.mutex);
    s.RethrowWorkerError();
    const int lag = s.options.fixed_lag;
    if (lag > 0) {
      // The in-flight result is taken at its frame + lag exactly.
      if (s.in_flight >= 0 && s.frame - s.in_flight >= lag) {
        if (!s.result_ready) {
          const auto start = std::chrono::steady_clock::now();
          s.wake.wait(lock, [&] { return s.result_ready || s.error; });
          ++s.waits;
          s.wait_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
          s.RethrowWorkerError();
        }
        s.TakeResult();
        s.in_flight = -1;
      }
    } else if (s.result_ready) {
      s.TakeResult();
    }
    const bool hand_over = lag > 0 ? (s.in_flight < 0 && (s.last_run < 0 || force_run ||
                                                           s.frame - s.last_run >= std::max(s.options.interval, lag)))
                                   : (due && !s.busy && !s.job_pending);
    if (hand_over) {
      if (lag > 0) s.in_flight = s.frame;
      s.last_run = s.frame;
      if (!s.options.threaded) {
        // Sequential with a fixed lag: the run happens here, its result is
        // taken `lag` frames later as in a threaded run.
        s.result = s.segmenter->Segment(input);
        s.result_frame = s.frame;
        s.result_ready = true;
      } else {
        s.job = SegmenterInput{input.rgb.clone(), input.depth.clone(), input.name};
        s.job_frame = s.frame;
        s.job_pending = true;
        s.wake.notify_all();
      }
    }
    if (s.source_frame < 0) {
      // Nothing yet: wait for the first result so that the sequence starts with a mask.
      s.wake.wait(lock, [&] { return s.result_ready || s.error || (!s.busy && !s.job_pending); });
      s.RethrowWorkerError();
      if (s.result_ready) s.TakeResult();
      s.in_flight = -1;
    }
  }
  ScheduledSegmentation out;
  if (s.mask.empty()) s.mask = cv::Mat(input.rgb.size(), CV_8UC1, cv::Scalar(0));
  out.mask = s.mask.clone();
  out.detections = s.detections;
  out.source_frame = s.source_frame;
  out.fresh = s.source_frame == s.frame;
  return out;
}

}  // namespace dypho
