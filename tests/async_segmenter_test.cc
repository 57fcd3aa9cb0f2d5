// The asynchronous segmenter (masking/async_segmenter.h) on a synthetic
// sequence with exact masks: runs every n-th frame and masks carried along
// the flow between, in its own thread, with a fixed lag (the same masks on a
// fast and a slow machine and sequentially), looking ahead (each detector
// frame its own mask, the same on any machine), and the worker's errors.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/check.h"
#include "masking/async_segmenter.h"
#include "masking/flow_motion.h"
#include "tests/synth_sequence.h"
#include "tests/test_data.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

using testing::Gray;
using testing::MaskIou;
using testing::SynthSequence;

// A segmenter that returns the sequence's true mask for frame <name>, after
// an optional delay, and counts its runs.
class TruthSegmenter : public Segmenter {
 public:
  TruthSegmenter(const std::vector<SynthFrame>* frames, int delay_ms, std::atomic<int>* runs)
      : frames_(frames), delay_ms_(delay_ms), runs_(runs) {}
  Segmentation Segment(const SegmenterInput& input) override {
    CheckSegmenterInput(input);
    if (delay_ms_ > 0) std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms_));
    ++*runs_;
    return {CvView((*frames_)[std::stoi(input.name)].mask).clone(), {}};
  }
  std::string Name() const override { return "truth"; }

 private:
  const std::vector<SynthFrame>* frames_;
  int delay_ms_;
  std::atomic<int>* runs_;
};

class ThrowingSegmenter : public Segmenter {
 public:
  Segmentation Segment(const SegmenterInput&) override { throw InvalidInput("segmenter exploded"); }
  std::string Name() const override { return "throwing"; }
};

TEST_F(SynthSequence, AsyncSegmenterRunsEveryNthFrameAndCarriesMasksBetween) {
  std::atomic<int> runs{0};
  SegmenterScheduleOptions o;
  o.interval = 3;
  AsyncSegmenter async(std::make_unique<TruthSegmenter>(frames_, 0, &runs), o);
  FlowMotion motion(FlowMotionOptions(), Cam());
  for (int i = 0; i < 8; ++i) {
    BackwardFlow flow;
    if (i > 0) flow = motion.ComputeFlow(Gray(Rgb(i)), Gray(Rgb(i - 1)));
    const ScheduledSegmentation s = async.Next({Rgb(i), Depth(i), std::to_string(i)}, flow, /*force_run=*/i == 7);
    const bool expect_run = i % 3 == 0 || i == 7;
    EXPECT_EQ(s.fresh, expect_run) << "frame " << i;
    EXPECT_EQ(s.source_frame, expect_run ? i : i - i % 3) << "frame " << i;
    EXPECT_GT(MaskIou(s.mask, Mask(i)), expect_run ? 0.999 : 0.8) << "frame " << i;
  }
  EXPECT_EQ(runs.load(), 4);  // frames 0, 3, 6 and the forced 7
  EXPECT_EQ(async.frames(), 8);
}

TEST_F(SynthSequence, AsyncSegmenterInItsOwnThreadDeliversCarriedResults) {
  std::atomic<int> runs{0};
  SegmenterScheduleOptions o;
  o.threaded = true;
  // 150 ms a run: slower than the frames come, even on a loaded machine.
  AsyncSegmenter async(std::make_unique<TruthSegmenter>(frames_, 150, &runs), o);
  FlowMotion motion(FlowMotionOptions(), Cam());
  long last_source = -1;
  for (int i = 0; i < kFrames; ++i) {
    BackwardFlow flow;
    if (i > 0) flow = motion.ComputeFlow(Gray(Rgb(i)), Gray(Rgb(i - 1)));
    const ScheduledSegmentation s = async.Next({Rgb(i), Depth(i), std::to_string(i)}, flow);
    if (i == 0) EXPECT_TRUE(s.fresh);  // the first frame waits for its result
    EXPECT_GE(s.source_frame, last_source);
    EXPECT_LE(s.source_frame, i);
    last_source = s.source_frame;
    // Carried along the flow, the mask follows the walkers better than the
    // result of its frame would as it is.
    const double iou = MaskIou(s.mask, Mask(i));
    EXPECT_GT(iou, 0.6) << "frame " << i << " (mask from frame " << s.source_frame << ")";
    if (s.source_frame >= 0 && s.source_frame + 2 <= i)
      EXPECT_GT(iou, MaskIou(Mask(s.source_frame), Mask(i))) << "frame " << i;
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  EXPECT_GE(runs.load(), 2);
  EXPECT_LT(runs.load(), kFrames);  // it could not keep up with every frame
  EXPECT_GT(last_source, 0);
}

TEST_F(SynthSequence, AsyncSegmenterWithAFixedLagGivesTheSameMasksOnAFastAndASlowMachine) {
  EXPECT_EQ(MaskLagForAge(5, 1), 3);  // runs on frames 0, 3, 6...: masks 3..5 frames old
  EXPECT_EQ(MaskLagForAge(4, 1), 2);
  EXPECT_EQ(MaskLagForAge(1, 1), 1);
  EXPECT_EQ(MaskLagForAge(6, 3), 3);
  EXPECT_EQ(MaskLagForAge(2, 3), 0);
  // Lag 2: runs handed over on frames 0, 2, 4, ...; the result of frame j
  // used from frame j + 2 on (frame 0 waits for its own). A detector of 0 ms
  // and one of 120 ms (it makes every later frame wait) give the same
  // sources and the same masks, and so does the sequential schedule (not
  // threaded: the run on the caller's thread, its result kept 2 frames).
  constexpr int kRuns = 3;
  std::vector<std::vector<long>> sources(kRuns);
  std::vector<std::vector<cv::Mat>> masks(kRuns);
  std::vector<long> waits(kRuns);
  std::vector<int> segmenter_runs(kRuns);
  for (int run = 0; run < kRuns; ++run) {
    std::atomic<int> runs{0};
    SegmenterScheduleOptions o;
    o.threaded = run < 2;
    o.fixed_lag = 2;
    AsyncSegmenter async(std::make_unique<TruthSegmenter>(frames_, run == 1 ? 120 : 0, &runs), o);
    FlowMotion motion(FlowMotionOptions(), Cam());
    for (int i = 0; i < 10; ++i) {
      BackwardFlow flow;
      if (i > 0) flow = motion.ComputeFlow(Gray(Rgb(i)), Gray(Rgb(i - 1)));
      const ScheduledSegmentation s = async.Next({Rgb(i), Depth(i), std::to_string(i)}, flow);
      sources[run].push_back(s.source_frame);
      masks[run].push_back(s.mask);
      if (run == 0) std::this_thread::sleep_for(std::chrono::milliseconds(30));  // the detector is always early
    }
    waits[run] = async.waits();
    segmenter_runs[run] = runs.load();
  }
  for (int i = 0; i < 10; ++i) {
    const long expected = i < 4 ? 0 : 2 * (i / 2) - 2;
    for (int run = 0; run < kRuns; ++run) {
      EXPECT_EQ(sources[run][i], expected) << "run " << run << ", frame " << i;
      EXPECT_EQ(cv::norm(masks[0][i], masks[run][i], cv::NORM_L1), 0.0) << "run " << run << ", frame " << i;
    }
  }
  EXPECT_EQ(segmenter_runs[2], 5);  // frames 0, 2, 4, 6, 8
  EXPECT_EQ(waits[2], 0);
  EXPECT_EQ(waits[1], 3);  // frames 4, 6 and 8 waited for the slow detector
}

TEST_F(SynthSequence, AsyncSegmenterRethrowsTheWorkersError) {
  for (bool threaded : {false, true}) {
    SegmenterScheduleOptions o;
    o.threaded = threaded;
    AsyncSegmenter async(std::make_unique<ThrowingSegmenter>(), o);
    EXPECT_INVALID_INPUT(async.Next({Rgb(0), Depth(0), "0"}, BackwardFlow()), "segmenter exploded");
  }
}


// Look-ahead 2, a run every 3 frames: frame j offers frame j + 2; the
// detector frames 0, 3, 6, 9 get their own masks (0 segmented at once,
// the others loaded and segmented on the worker), frames between the
// carried ones. A detector of 0 ms (the caller slower), one of 120 ms (the
// frames wait) and the sequential schedule give the same masks.
TEST_F(SynthSequence, AsyncSegmenterLookingAheadGivesDetectorFramesTheirOwnMasksOnAnyMachine) {
  constexpr int kRuns = 3;
  std::vector<std::vector<cv::Mat>> masks(kRuns);
  for (int run = 0; run < kRuns; ++run) {
    std::atomic<int> runs{0};
    SegmenterScheduleOptions o;
    o.threaded = run < 2;
    o.interval = 3;
    o.look_ahead = 2;
    AsyncSegmenter async(std::make_unique<TruthSegmenter>(frames_, run == 1 ? 120 : 0, &runs), o);
    FlowMotion motion(FlowMotionOptions(), Cam());
    std::mutex mutex;
    std::vector<int> loaded;
    std::vector<std::thread::id> loader_threads;
    for (int i = 0; i < kFrames; ++i) {
      BackwardFlow flow;
      if (i > 0) flow = motion.ComputeFlow(Gray(Rgb(i)), Gray(Rgb(i - 1)));
      AheadLoader ahead;
      if (i + 2 < kFrames)
        ahead = [&, j = i + 2]() -> std::optional<SegmenterInput> {
          std::lock_guard<std::mutex> lock(mutex);
          loaded.push_back(j);
          loader_threads.push_back(std::this_thread::get_id());
          return SegmenterInput{Rgb(j).clone(), Depth(j).clone(), std::to_string(j)};
        };
      const ScheduledSegmentation s = async.Next({Rgb(i), Depth(i), std::to_string(i)}, flow, false, ahead);
      EXPECT_EQ(s.source_frame, i - i % 3) << "run " << run << ", frame " << i;
      EXPECT_EQ(s.fresh, i % 3 == 0) << "run " << run << ", frame " << i;
      EXPECT_GT(MaskIou(s.mask, Mask(i)), i % 3 == 0 ? 0.999 : 0.8) << "run " << run << ", frame " << i;
      masks[run].push_back(s.mask);
      if (run == 0) std::this_thread::sleep_for(std::chrono::milliseconds(30));  // the detector is always early
    }
    EXPECT_EQ(runs.load(), 4) << "run " << run;  // frames 0, 3, 6, 9
    if (o.threaded) {
      EXPECT_EQ(loaded, (std::vector<int>{3, 6, 9})) << "run " << run;
      for (const std::thread::id& id : loader_threads) EXPECT_NE(id, std::this_thread::get_id());
    } else {
      EXPECT_TRUE(loaded.empty()) << "sequential: each detector frame segmented when it comes";
    }
    if (run == 0) EXPECT_EQ(async.waits(), 0);
    if (run == 1) EXPECT_EQ(async.waits(), 3);  // frames 3, 6 and 9 waited for the slow detector
  }
  for (int i = 0; i < kFrames; ++i)
    for (int run = 1; run < kRuns; ++run)
      EXPECT_EQ(cv::norm(masks[0][i], masks[run][i], cv::NORM_L1), 0.0) << "run " << run << ", frame " << i;
}

// A loader that gives another frame than the one due (a frame in between
// could not be read) or none: its result is not used, the detector frame is
// segmented when it comes.
TEST_F(SynthSequence, AsyncSegmenterLookingAheadDropsAResultOfAnotherFrame) {
  std::atomic<int> runs{0};
  SegmenterScheduleOptions o;
  o.threaded = true;
  o.interval = 3;
  o.look_ahead = 2;
  AsyncSegmenter async(std::make_unique<TruthSegmenter>(frames_, 0, &runs), o);
  for (int i = 0; i < 7; ++i) {
    AheadLoader ahead = [i]() -> std::optional<SegmenterInput> {
      if (i + 2 == 6) return std::nullopt;  // frame 6 unreadable
      return SegmenterInput{Rgb(i + 3).clone(), Depth(i + 3).clone(), std::to_string(i + 3)};  // one too far
    };
    const ScheduledSegmentation s = async.Next({Rgb(i), Depth(i), std::to_string(i)}, BackwardFlow(), false, ahead);
    EXPECT_EQ(s.source_frame, i - i % 3) << "frame " << i;
    if (i % 3 == 0) EXPECT_GT(MaskIou(s.mask, Mask(i)), 0.999) << "frame " << i;
  }
  EXPECT_EQ(runs.load(), 4);  // frame 0, the wrong frame 4, then frames 3 and 6 at once
}

TEST(AsyncSegmenterOptions, LookAheadIsCheckedAgainstTheSchedule) {
  SegmenterScheduleOptions o;
  o.interval = 3;
  o.look_ahead = 4;
  EXPECT_INVALID_INPUT(AsyncSegmenter(CreateSegmenter(SegmenterOptions()), o), "look_ahead must be in 0..interval (3)");
  o.look_ahead = 2;
  o.fixed_lag = 1;
  EXPECT_INVALID_INPUT(AsyncSegmenter(CreateSegmenter(SegmenterOptions()), o), "look_ahead and fixed_lag");
}

}  // namespace
}  // namespace dypho
