#include "engine/pipeline/live_replay.h"

#include <chrono>
#include <thread>

#include "common/check.h"

namespace dypho {

LiveReplay::LiveReplay(std::vector<double> timestamps, double speed, Now now, SleepUntil sleep_until)
    : timestamps_(std::move(timestamps)), speed_(speed), now_(std::move(now)), sleep_until_(std::move(sleep_until)) {
  DYPHO_CHECK_INPUT(speed_ > 0.0) << "realtime_speed must be > 0 (got " << speed_ << ")";
  for (size_t i = 1; i < timestamps_.size(); ++i)
    DYPHO_CHECK_INPUT(timestamps_[i] >= timestamps_[i - 1])
        << "realtime: frame timestamps must not decrease (frame " << i << ": " << timestamps_[i] << " after "
        << timestamps_[i - 1] << ")";
  if (!now_) {
    now_ = [] {
      return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
    };
  }
  if (!sleep_until_) {
    sleep_until_ = [this](double t) {
      const double wait = t - now_();
      if (wait > 0) std::this_thread::sleep_for(std::chrono::duration<double>(wait));
    };
  }
}

double LiveReplay::arrival(long i) const {
  return (timestamps_[static_cast<size_t>(i)] - timestamps_.front()) / speed_;
}

long LiveReplay::Next(long last) {
  const long n = static_cast<long>(timestamps_.size());
  if (last + 1 >= n) return -1;
  if (!started_) {
    started_ = true;
    start_ = now_();
  }
  const double now = now_() - start_;
  // The newest frame that has arrived; frame last + 1 if none has (wait for it).
  long next = last + 1;
  while (next + 1 < n && arrival(next + 1) <= now) ++next;
  if (arrival(next) > now) {
    sleep_until_(start_ + arrival(next));
  }
  dropped_ += next - last - 1;
  return next;
}

}  // namespace dypho
