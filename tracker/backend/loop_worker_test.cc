// The loop worker (tracker/backend/loop_worker.h): jobs are processed one at
// a time in the order submitted and taken in that order; Take never blocks;
// WaitAndTake waits for the oldest job; the destructor finishes the job in
// flight; a job that throws is taken as its exception, threaded or not.
#include "tracker/backend/loop_worker.h"

#include <gtest/gtest.h>

#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace dypho {
namespace {

LoopJob Job(long frame, int keyframe) {
  LoopJob j;
  j.frame = frame;
  j.keyframe = keyframe;
  j.reset = true;  // no snapshot needed here
  return j;
}

TEST(LoopWorker, ProcessesJobsInOrderAndTakesThemInOrder) {
  std::mutex m;
  std::condition_variable cv;
  bool open = false;
  std::vector<int> seen;
  LoopWorker worker([&](LoopJob job) {
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [&] { return open; });  // held until the test opens the gate
    seen.push_back(job.keyframe);
    LoopOutcome o;
    o.frame = job.frame;
    o.keyframe = job.keyframe;
    return o;
  });
  EXPECT_EQ(worker.OldestFrame(), -1);
  EXPECT_FALSE(worker.WaitAndTake().has_value());  // nothing in flight: no wait
  worker.Submit(Job(10, 3));
  worker.Submit(Job(12, 4));
  worker.Submit(Job(15, 5));
  EXPECT_EQ(worker.InFlight(), 3);
  EXPECT_EQ(worker.OldestFrame(), 10);
  EXPECT_FALSE(worker.Take().has_value());  // the first job is held: not ready, no block
  {
    std::lock_guard<std::mutex> lock(m);
    open = true;
  }
  cv.notify_all();
  for (int k : {3, 4, 5}) {
    const std::optional<LoopOutcome> o = worker.WaitAndTake();
    ASSERT_TRUE(o.has_value());
    EXPECT_EQ(o->keyframe, k);
  }
  EXPECT_EQ(worker.InFlight(), 0);
  EXPECT_EQ(worker.OldestFrame(), -1);
  EXPECT_EQ(seen, (std::vector<int>{3, 4, 5}));
}

TEST(LoopWorker, DestructorFinishesTheJobInFlight) {
  int processed = 0;
  {
    LoopWorker worker([&](LoopJob job) {
      ++processed;
      LoopOutcome o;
      o.frame = job.frame;
      return o;
    });
    worker.Submit(Job(1, 0));
    worker.WaitAndTake();
    worker.Submit(Job(2, 1));
  }  // joins: the second job ran or was dropped before it started, never half
  EXPECT_GE(processed, 1);
  EXPECT_LE(processed, 2);
}

TEST(LoopWorker, SynchronousProcessesInSubmitAndKeepsTheOutcomesInOrder) {
  std::vector<int> seen;
  LoopWorker worker(
      [&](LoopJob job) {
        seen.push_back(job.keyframe);
        LoopOutcome o;
        o.frame = job.frame;
        o.keyframe = job.keyframe;
        return o;
      },
      /*synchronous=*/true);
  worker.Submit(Job(10, 3));
  EXPECT_EQ(seen, (std::vector<int>{3}));  // processed in Submit
  worker.Submit(Job(12, 4));
  EXPECT_EQ(worker.InFlight(), 2);
  EXPECT_EQ(worker.OldestFrame(), 10);
  for (int k : {3, 4}) {
    const std::optional<LoopOutcome> o = worker.Take();  // ready: never blocks
    ASSERT_TRUE(o.has_value());
    EXPECT_EQ(o->keyframe, k);
  }
  EXPECT_EQ(worker.InFlight(), 0);
  EXPECT_FALSE(worker.WaitAndTake().has_value());
}


// Keyframe 4's processing throws: threaded, its outcome is that exception
// (the worker thread lives on, the next job is taken after it);
// synchronous, Submit throws and nothing is left waiting.
TEST(LoopWorker, AJobThatThrowsIsTakenAsItsExceptionAndNothingWaitsForever) {
  auto process = [](LoopJob job) {
    if (job.keyframe == 4) throw std::runtime_error("closure failed");
    LoopOutcome o;
    o.keyframe = job.keyframe;
    return o;
  };
  {
    LoopWorker worker(process);
    worker.Submit(Job(10, 3));
    worker.Submit(Job(11, 4));
    worker.Submit(Job(12, 5));
    EXPECT_EQ(worker.WaitAndTake()->keyframe, 3);
    EXPECT_EQ(worker.OldestFrame(), 11);
    EXPECT_THROW(worker.WaitAndTake(), std::runtime_error);
    EXPECT_EQ(worker.OldestFrame(), 12);
    EXPECT_EQ(worker.WaitAndTake()->keyframe, 5);
    EXPECT_EQ(worker.InFlight(), 0);
  }
  LoopWorker sync(process, /*synchronous=*/true);
  sync.Submit(Job(10, 3));
  EXPECT_THROW(sync.Submit(Job(11, 4)), std::runtime_error);
  EXPECT_EQ(sync.InFlight(), 1);
  EXPECT_EQ(sync.WaitAndTake()->keyframe, 3);
  EXPECT_FALSE(sync.WaitAndTake().has_value());  // returns: nothing listed for the failed job
}

}  // namespace
}  // namespace dypho
