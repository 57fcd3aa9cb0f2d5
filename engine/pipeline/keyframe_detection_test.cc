// The detector run again on keyframes (engine/pipeline/keyframe_detection.h),
// here with a PNG-folder "detector" whose answers are known: a keyframe
// whose mask was carried gets its frame's segmentation, one with a fresh
// mask nothing; a claimed keyframe is answered however many frames later
// the mapping thread asks, an unclaimed one only within the recent window.
#include "engine/pipeline/keyframe_detection.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "engine/map/keyframe_selector.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

constexpr int kW = 16, kH = 12;

struct Fixture {
  std::string folder;
  std::unique_ptr<KeyframeDetection> detection;
  std::vector<uint8_t> rgb = std::vector<uint8_t>(kW * kH * 3, 90);

  Fixture() {
    folder = testing::TestTempDir();
    SegmenterOptions o;
    o.kind = "png-folder";
    o.png_folder = folder;
    Camera c;
    c.fx = c.fy = 20;
    c.cx = kW / 2.0;
    c.cy = kH / 2.0;
    c.width = kW;
    c.height = kH;
    detection = std::make_unique<KeyframeDetection>(o, c, 1);
  }
  // Frame t's mask file: column t dynamic.
  void WriteMask(int t) const {
    cv::Mat m(kH, kW, CV_8UC1, cv::Scalar(0));
    m.col(t).setTo(255);
    cv::imwrite(folder + "/f" + std::to_string(t) + ".png", m);
  }
  std::vector<uint8_t> Ask(int t) {
    KeyframeMaskRequest r;
    r.timestamp = t;
    r.width = kW;
    r.height = kH;
    r.rgb = rgb.data();
    return (*detection)(r);
  }
};

void ExpectColumn(const std::vector<uint8_t>& mask, int t) {
  ASSERT_EQ(mask.size(), static_cast<size_t>(kW * kH));
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) EXPECT_EQ(mask[y * kW + x] != 0, x == t) << x << "," << y;
}

TEST(KeyframeDetection, CarriedKeyframesGetTheirFrameSegmentationFreshOnesNothing) {
  Fixture f;
  for (int t = 1; t <= 3; ++t) f.WriteMask(t);
  f.detection->Note(1, "f1", /*fresh=*/false);
  f.detection->Note(2, "f2", /*fresh=*/true);
  f.detection->Note(3, "f3", /*fresh=*/false);
  ExpectColumn(f.Ask(3), 3);
  EXPECT_TRUE(f.Ask(2).empty());
  ExpectColumn(f.Ask(1), 1);
  EXPECT_TRUE(f.Ask(9).empty()) << "never noted";
  EXPECT_EQ(f.detection->runs(), 2);
}

TEST(KeyframeDetection, AClaimedKeyframeIsAnsweredAfterTheWindowHasMovedOn) {
  Fixture f;
  f.WriteMask(1);
  f.WriteMask(2);
  f.detection->Note(1, "f1", false);
  f.detection->Note(2, "f2", false);
  f.detection->Claim(1);  // keyframe 1 emitted; keyframe 2 never claimed
  const int later = static_cast<int>(kKeyframeCandidateFrames) + 10;
  for (int t = 3; t < 3 + later; ++t) f.detection->Note(t, "none", false);
  ExpectColumn(f.Ask(1), 1);  // the mapping thread asks late
  EXPECT_TRUE(f.Ask(2).empty()) << "unclaimed and out of the window";
  EXPECT_TRUE(f.Ask(1).empty()) << "a claim is answered once";
  EXPECT_EQ(f.detection->runs(), 1);
}

}  // namespace
}  // namespace dypho
