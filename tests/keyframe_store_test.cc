// Waiting keyframes (engine/map/keyframe_store.h): packing is lossless for
// colour and masks and within the depth quantum; the store keeps order,
// respects its memory limit by spilling to files, refuses (instead of
// dropping) when it has no spill folder, and cleans its files up.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "engine/map/keyframe_store.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

// A 640x480 keyframe whose colour is noise (PNG cannot shrink it much), a
// depth ramp from 0.5 m to `max_depth`, a masked rectangle and two features.
KeyframeInput MakeInput(int seed, float max_depth = 4.0f) {
  KeyframeInput in;
  const int w = 640, h = 480;
  in.timestamp = 100.0 + seed;
  in.rgb = ImageU8(w, h, 3);
  std::mt19937 rng(seed);
  for (uint8_t& v : in.rgb.pixels()) v = static_cast<uint8_t>(rng() & 0xff);
  in.depth = ImageF(w, h, 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      in.depth.data()[y * w + x] = (x + y) % 97 == 0 ? 0.0f : 0.5f + (max_depth - 0.5f) * x / (w - 1);
    }
  }
  in.dynamic_mask = ImageU8(w, h, 1);
  for (int y = 100; y < 200; ++y) {
    for (int x = 300; x < 420; ++x) in.dynamic_mask.data()[y * w + x] = 255;
  }
  in.cam_from_world = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * seed, Eigen::Vector3d::UnitY())),
                              Eigen::Vector3d(0.1, -0.2 * seed, 0.3));
  in.angular_velocity = Eigen::Vector3d(0.5, -0.25, 0.125 * seed);
  in.features = {{10.5f, 20.25f, 1.5f}, {600.0f, 400.0f, 0.0f}};
  return in;
}

void ExpectSame(const KeyframeInput& a, const KeyframeInput& b, float depth_quantum) {
  EXPECT_EQ(a.timestamp, b.timestamp);
  EXPECT_EQ(a.rgb.pixels(), b.rgb.pixels());
  EXPECT_EQ(a.dynamic_mask.pixels(), b.dynamic_mask.pixels());
  ASSERT_EQ(a.depth.size(), b.depth.size());
  float worst = 0.0f;
  for (size_t i = 0; i < a.depth.size(); ++i) worst = std::max(worst, std::abs(a.depth.data()[i] - b.depth.data()[i]));
  EXPECT_LE(worst, 0.5f * depth_quantum + 1e-6f);
  EXPECT_LT((a.cam_from_world.translation - b.cam_from_world.translation).norm(), 1e-15);
  EXPECT_LT(a.cam_from_world.rotation.angularDistance(b.cam_from_world.rotation), 1e-12);
  EXPECT_EQ(a.angular_velocity, b.angular_velocity);
  ASSERT_EQ(a.features.size(), b.features.size());
  for (size_t i = 0; i < a.features.size(); ++i) {
    EXPECT_EQ(a.features[i].x, b.features[i].x);
    EXPECT_EQ(a.features[i].depth, b.features[i].depth);
  }
}

TEST(KeyframeStore, PackingKeepsColourMaskAndPoseExactAndDepthWithinItsQuantum) {
  const KeyframeInput in = MakeInput(1);
  const PackedKeyframe packed = PackKeyframe(in);
  EXPECT_EQ(packed.depth_factor, 5000.0f);  // the TUM encoding for depths up to 13.1 m
  ExpectSame(in, UnpackKeyframe(packed), 1.0f / 5000.0f);
  // Farther depths get a coarser quantum so that the 16 bits still reach.
  const KeyframeInput far = MakeInput(2, 40.0f);
  const PackedKeyframe far_packed = PackKeyframe(far);
  EXPECT_NEAR(far_packed.depth_factor, 65535.0f / 40.0f, 1e-2f);
  ExpectSame(far, UnpackKeyframe(far_packed), 40.0f / 65535.0f);
  // A smooth image compresses; noise does not: packing is real compression.
  KeyframeInput smooth = MakeInput(3);
  for (size_t i = 0; i < smooth.rgb.size(); ++i) smooth.rgb.data()[i] = static_cast<uint8_t>((i / 3) % 640 / 3);
  EXPECT_LT(PackKeyframe(smooth).bytes(), smooth.rgb.size() / 4);
}

TEST(KeyframeStore, SpillsBeyondItsMemoryLimitAndKeepsOrder) {
  const std::string dir = testing::TestTempDir() + "/spill";
  const size_t packed_size = PackKeyframe(MakeInput(0)).bytes();
  KeyframeStoreOptions o;
  o.raw_capacity = 2;
  o.memory_limit_bytes = std::max<size_t>(size_t{1} << 20, 3 * packed_size + packed_size / 2);  // room for 3 packed
  o.spill_dir = dir;
  {
    KeyframeStore store(o);
    for (int i = 0; i < 10; ++i) ASSERT_TRUE(store.Put(i, MakeInput(i)));
    const KeyframeStoreStats s = store.stats();
    EXPECT_EQ(s.waiting, 10);
    const int in_memory = static_cast<int>(o.memory_limit_bytes / packed_size);
    EXPECT_EQ(s.packed, std::min(8, in_memory));
    EXPECT_EQ(s.spilled, 8 - s.packed);
    EXPECT_GT(s.spilled, 0);
    EXPECT_LE(s.packed_bytes, o.memory_limit_bytes);
    EXPECT_EQ(static_cast<int>(std::distance(std::filesystem::directory_iterator(dir),
                                             std::filesystem::directory_iterator())),
              s.spilled);
    // A correction reaches a keyframe while it waits (spilled or not).
    const Rigid3d moved(Eigen::Quaterniond::Identity(), Eigen::Vector3d(7, 8, 9));
    EXPECT_TRUE(store.SetPose(9, moved));
    EXPECT_FALSE(store.SetPose(42, moved));
    Rigid3d got;
    EXPECT_TRUE(store.GetPose(9, &got));
    EXPECT_EQ(got.translation, moved.translation);
    for (int i = 0; i < 6; ++i) {
      auto [id, input] = store.Take();
      EXPECT_EQ(id, i);
      ExpectSame(MakeInput(i), input, 1.0f / 5000.0f);
    }
    EXPECT_EQ(store.stats().total_spilled, s.spilled);
    EXPECT_EQ(store.stats().total_packed, 8);
  }
  // The store removed its spill files and the (then empty) folder.
  EXPECT_FALSE(std::filesystem::exists(dir));
}

// A stereo keyframe still waiting for its dense depth (KeyframeInput::right_rgb)
// keeps its right image exactly, packed in memory and spilled to a file.
TEST(KeyframeStore, PackingAndSpillingKeepTheStereoRightImage) {
  auto with_right = [](int seed) {
    KeyframeInput in = MakeInput(seed);
    in.right_rgb = ImageU8(in.rgb.width(), in.rgb.height(), 3);
    std::mt19937 rng(1000 + seed);
    for (uint8_t& v : in.right_rgb.pixels()) v = static_cast<uint8_t>(rng() & 0xff);
    return in;
  };
  const KeyframeInput in = with_right(1);
  const PackedKeyframe packed = PackKeyframe(in);
  EXPECT_GT(packed.right_png.size(), in.right_rgb.size() / 2);  // noise: counted in bytes()
  EXPECT_EQ(packed.bytes(), packed.rgb_png.size() + packed.depth_png.size() + packed.mask_png.size() +
                                packed.right_png.size());
  EXPECT_EQ(UnpackKeyframe(packed).right_rgb.pixels(), in.right_rgb.pixels());
  EXPECT_TRUE(UnpackKeyframe(PackKeyframe(MakeInput(2))).right_rgb.empty());

  KeyframeStoreOptions o;
  o.raw_capacity = 0;
  o.memory_limit_bytes = size_t{1} << 20;  // about one packed stereo keyframe
  o.spill_dir = testing::TestTempDir() + "/spill_stereo";
  KeyframeStore store(o);
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(store.Put(i, with_right(i)));
  EXPECT_GT(store.stats().spilled, 0);
  for (int i = 0; i < 4; ++i) {
    auto [id, input] = store.Take();
    EXPECT_EQ(id, i);
    EXPECT_EQ(input.right_rgb.pixels(), with_right(i).right_rgb.pixels()) << "keyframe " << i;
    ExpectSame(with_right(i), input, 1.0f / 5000.0f);
  }
}

TEST(KeyframeStore, WithoutASpillFolderItRefusesInsteadOfDropping) {
  const size_t packed_size = PackKeyframe(MakeInput(0)).bytes();
  KeyframeStoreOptions o;
  o.raw_capacity = 1;
  o.memory_limit_bytes = std::max<size_t>(size_t{1} << 20, packed_size + packed_size / 2);
  KeyframeStore store(o);
  int accepted = 0;
  while (store.Put(accepted, MakeInput(accepted))) ++accepted;
  EXPECT_EQ(accepted, 1 + static_cast<int>(o.memory_limit_bytes / packed_size));
  EXPECT_EQ(store.size(), accepted);  // the refused one is not half-kept
  EXPECT_EQ(store.Take().first, 0);   // the raw one leaves: its place takes the next one unpacked
  EXPECT_TRUE(store.Put(accepted, MakeInput(accepted)));
  EXPECT_FALSE(store.Put(accepted + 1, MakeInput(accepted + 1)));  // full again
  EXPECT_EQ(store.Take().first, 1);   // a packed one leaves: room for a packed one
  EXPECT_TRUE(store.Put(accepted + 1, MakeInput(accepted + 1)));
  int last = -1;
  while (!store.empty()) last = store.Take().first;
  EXPECT_EQ(last, accepted + 1);
}

TEST(KeyframeStore, BadOptionsAreClearErrors) {
  KeyframeStoreOptions o;
  o.memory_limit_bytes = 10;
  EXPECT_INVALID_INPUT(KeyframeStore{o}, "memory limit");
  o = KeyframeStoreOptions();
  o.raw_capacity = -1;
  EXPECT_INVALID_INPUT(KeyframeStore{o}, "raw_capacity");
}

}  // namespace
}  // namespace dypho
