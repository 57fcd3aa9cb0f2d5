// `dypho run --realtime`: a recorded dataset replayed as a live camera
// delivers it. Frame i arrives (t_i - t_0) / speed seconds after the replay
// starts. A live camera keeps only its newest frame: when the tracking
// thread asks for the next frame it gets the newest one that has arrived
// (the ones it skips are dropped, counted) or, when none has arrived since
// its last frame, waits for the next one. A frame is dropped only when a
// newer one had already arrived, so no more are dropped than the tracking
// thread's speed forces.
#pragma once

#include <functional>
#include <vector>

namespace dypho {

class LiveReplay {
 public:
  // Seconds since some fixed point, and a sleep until such a time.
  using Now = std::function<double()>;
  using SleepUntil = std::function<void(double)>;

  // `timestamps`: the frames' times [s], non-decreasing; `speed` > 0.
  // Without `now`/`sleep_until`, the steady clock and a real sleep (tests
  // pass a simulated clock). The replay starts at the first call to Next.
  // Throws InvalidInput for decreasing timestamps or speed <= 0.
  LiveReplay(std::vector<double> timestamps, double speed, Now now = nullptr, SleepUntil sleep_until = nullptr);

  // The position of the frame the tracking thread processes after the one
  // at `last` (-1: the first frame), or -1 when the replay has ended.
  long Next(long last);
  // Frames dropped so far.
  long dropped() const { return dropped_; }
  // When frame `i` arrives [s after the start].
  double arrival(long i) const;

 private:
  std::vector<double> timestamps_;
  double speed_;
  Now now_;
  SleepUntil sleep_until_;
  bool started_ = false;
  double start_ = 0.0;
  long dropped_ = 0;
};

}  // namespace dypho
