// The held-back frames (engine/holdout_frames.h): which frames are kept
// (every n-th offered, thinned evenly when full), the same with the packing
// on its own thread as inline, frames made only when kept, the frames
// unpacked exactly, an error in making one reaching Unpacked.
#include "engine/holdout_frames.h"

#include <gtest/gtest.h>

#include <atomic>
#include <string>

#include "common/check.h"

namespace dypho {
namespace {

KeyframeInput Frame(int i) {
  KeyframeInput in;
  in.timestamp = i;
  in.rgb = ImageU8(16, 8, 3);
  for (size_t k = 0; k < in.rgb.size(); ++k) in.rgb.data()[k] = static_cast<uint8_t>(7 * i + 3 * k);
  in.depth = ImageF(16, 8, 1);
  for (size_t k = 0; k < in.depth.size(); ++k) in.depth.data()[k] = 0.5f + 0.01f * static_cast<float>(i);
  return in;
}

std::vector<double> KeptTimestamps(bool threaded, int offers, std::atomic<int>* made) {
  HoldoutFrames holdout(/*every=*/2, /*max_frames=*/4, threaded);
  for (int i = 1; i <= offers; ++i) {
    if (!holdout.Due()) continue;
    holdout.Add([made, i] {  // runs on the packing thread when threaded
      ++*made;
      return Frame(i);
    });
  }
  std::vector<double> t;
  for (const KeyframeInput& in : holdout.Unpacked()) {
    t.push_back(in.timestamp);
    const KeyframeInput expected = Frame(static_cast<int>(in.timestamp));
    EXPECT_EQ(in.rgb.width(), 16);
    for (size_t k = 0; k < in.rgb.size(); ++k) EXPECT_EQ(in.rgb.data()[k], expected.rgb.data()[k]) << k;
    for (size_t k = 0; k < in.depth.size(); ++k) EXPECT_NEAR(in.depth.data()[k], expected.depth.data()[k], 1e-3);
  }
  return t;
}

TEST(HoldoutFrames, EveryNthThinnedEvenlyTheSameOnItsOwnThread) {
  for (bool threaded : {false, true}) {
    std::atomic<int> made{0};
    // Every 2nd: 2 4 6 8 10 -> over 4: 2 6 10, every 4th: 14 18 -> 2 6 10 14 18 -> 2 10 18, every 8th.
    EXPECT_EQ(KeptTimestamps(threaded, 20, &made), (std::vector<double>{2, 10, 18})) << threaded;
    EXPECT_EQ(made, 7) << "frames built only when kept";
    made = 0;
    EXPECT_EQ(KeptTimestamps(threaded, 7, &made), (std::vector<double>{2, 4, 6})) << threaded;
  }
}

TEST(HoldoutFrames, AnErrorInMakingAFrameReachesUnpacked) {
  for (bool threaded : {false, true}) {
    HoldoutFrames holdout(/*every=*/1, /*max_frames=*/8, threaded);
    ASSERT_TRUE(holdout.Due());
    holdout.Add([] { return Frame(1); });
    ASSERT_TRUE(holdout.Due());
    holdout.Add([]() -> KeyframeInput { throw InvalidInput("depth file 'x.png' is unreadable"); });
    try {
      holdout.Unpacked();
      ADD_FAILURE() << "no error (threaded " << threaded << ")";
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("x.png"), std::string::npos) << e.what();
    }
  }
  // Destroyed with jobs still queued: they finish first.
  std::atomic<int> made{0};
  {
    HoldoutFrames holdout(1, 8, true);
    for (int i = 1; i <= 5; ++i) {
      ASSERT_TRUE(holdout.Due());
      holdout.Add([&made, i] {
        ++made;
        return Frame(i);
      });
    }
  }
  EXPECT_EQ(made, 5);
}

TEST(HoldoutFrames, NoneWhenOff) {
  HoldoutFrames holdout(0, 4, true);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(holdout.Due());
  EXPECT_TRUE(holdout.Unpacked().empty());
}

}  // namespace
}  // namespace dypho
