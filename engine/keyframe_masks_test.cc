// The keyframe-mask hook off the pushing thread (engine/keyframe_masks.h):
// each added keyframe is asked about once, with its own frame; the answer
// joins exactly its mask, whichever thread asked; at most max_pending whole
// frames wait, the oldest beyond that answered at once on the pushing thread.
#include "engine/keyframe_masks.h"

#include <gtest/gtest.h>

#include <thread>
#include <vector>

namespace dypho {
namespace {

constexpr int kW = 12, kH = 8;

Camera TestCamera() { return Camera{10, 10, 6, 4, kW, kH}; }

// Frame t: rgb value t everywhere; pushed mask: pixel (0, 0) dynamic.
PushedFrame Frame(int t) {
  PushedFrame f;
  f.timestamp = t;
  f.rgb = ImageU8(kW, kH, 3, static_cast<uint8_t>(t));
  f.depth = ImageF(kW, kH, 1, 1.0f);
  f.mask = ImageU8(kW, kH, 1, 0);
  f.mask.at(0, 0) = 255;
  return f;
}

KeyframeInput Input(int t) {
  KeyframeInput in;
  in.timestamp = t;
  in.dynamic_mask = ImageU8(kW, kH, 1, 0);
  in.dynamic_mask.at(0, 0) = 255;  // the pushed mask, as MakeKeyframeInput gives it
  return in;
}

struct Hook {
  std::vector<double> asked;
  std::vector<std::thread::id> threads;
  std::vector<bool> saw_own_frame;
};

// The hook marks column t of keyframe t (its answer depends on its frame only).
EngineOptions Options(Hook* hook) {
  EngineOptions o;
  o.camera = TestCamera();
  o.keyframe_mask = [hook](const KeyframeMaskRequest& r) {
    hook->asked.push_back(r.timestamp);
    hook->threads.push_back(std::this_thread::get_id());
    const int t = static_cast<int>(r.timestamp);
    hook->saw_own_frame.push_back(r.rgb[0] == t && r.dynamic_mask != nullptr && r.dynamic_mask[0] == 255);
    std::vector<uint8_t> m(static_cast<size_t>(r.width) * r.height, 0);
    for (int y = 0; y < r.height; ++y) m[static_cast<size_t>(y) * r.width + t] = 1;
    return m;
  };
  return o;
}

// Keyframe t's mask: the pushed pixel (0, 0) and the hook's column t (-1: none).
void ExpectJoined(const KeyframeInput& in, int t) {
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const bool dynamic = x == t || (x == 0 && y == 0);
      EXPECT_EQ(in.dynamic_mask.at(x, y), dynamic ? 255 : 0) << "keyframe " << t << " pixel " << x << "," << y;
    }
}

TEST(KeyframeMasks, AskedOnceWhenResolvedOnTheResolvingThread) {
  Hook hook;
  const EngineOptions o = Options(&hook);
  const Undistorter undistort(o.camera);
  KeyframeMasks masks(o, undistort, 8);
  for (int t = 1; t <= 3; ++t) masks.Add(Frame(t));
  EXPECT_TRUE(hook.asked.empty()) << "nothing asked on push while under the bound";
  std::thread mapping([&] {
    for (int t = 1; t <= 3; ++t) {
      KeyframeInput in = Input(t);
      masks.Resolve(&in);
      ExpectJoined(in, t);
    }
  });
  const std::thread::id mapping_id = mapping.get_id();
  mapping.join();
  ASSERT_EQ(hook.asked, (std::vector<double>{1, 2, 3}));
  for (const std::thread::id& id : hook.threads) EXPECT_EQ(id, mapping_id);
  for (bool own : hook.saw_own_frame) EXPECT_TRUE(own);
  const KeyframeMaskCounts c = masks.counts();
  EXPECT_EQ(c.asked, 3);
  EXPECT_EQ(c.on_push, 0);
  // Resolved once: a second Resolve (or a keyframe never added) is left as it is.
  KeyframeInput again = Input(2);
  masks.Resolve(&again);
  KeyframeInput never = Input(7);
  masks.Resolve(&never);
  EXPECT_EQ(hook.asked.size(), 3u);
  ExpectJoined(again, -1);
  ExpectJoined(never, -1);
}

TEST(KeyframeMasks, BeyondTheBoundTheOldestIsAnsweredOnPushWithTheSameResult) {
  Hook hook;
  const EngineOptions o = Options(&hook);
  const Undistorter undistort(o.camera);
  KeyframeMasks masks(o, undistort, 2);
  for (int t = 1; t <= 5; ++t) masks.Add(Frame(t));
  // 5 added, 2 may wait whole: 1, 2, 3 answered on push, oldest first.
  EXPECT_EQ(hook.asked, (std::vector<double>{1, 2, 3}));
  for (const std::thread::id& id : hook.threads) EXPECT_EQ(id, std::this_thread::get_id());
  for (int t = 1; t <= 5; ++t) {
    KeyframeInput in = Input(t);
    masks.Resolve(&in);
    ExpectJoined(in, t);
  }
  EXPECT_EQ(hook.asked, (std::vector<double>{1, 2, 3, 4, 5}));
  const KeyframeMaskCounts c = masks.counts();
  EXPECT_EQ(c.asked, 5);
  EXPECT_EQ(c.on_push, 3);
}

TEST(KeyframeMasks, NothingWithoutAHook) {
  EngineOptions o;
  o.camera = TestCamera();
  const Undistorter undistort(o.camera);
  KeyframeMasks masks(o, undistort, 0);
  masks.Add(Frame(1));
  KeyframeInput in = Input(1);
  masks.Resolve(&in);
  ExpectJoined(in, -1);
  EXPECT_EQ(masks.counts().asked, 0);
}

}  // namespace
}  // namespace dypho
