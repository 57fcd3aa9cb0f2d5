// The detector run again on keyframes (engine/pipeline/keyframe_detection.h),
// here with a PNG-folder "detector" whose answers are known: a keyframe
// whose mask was carried gets its frame's segmentation, one with a fresh
// mask nothing; a claimed keyframe is answered however many frames later
// the mapping thread asks, an unclaimed one only within the recent window.
// With the frame's background depth, the segmentation's pixels that agree
// with a supported background are static.
#include "engine/pipeline/keyframe_detection.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "common/check.h"
#include "engine/map/keyframe_selector.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

constexpr int kW = 16, kH = 12;

// A keyframe detection whose "detector" reads the masks of `folder`, for a
// w x h pinhole camera of focal length f.
std::unique_ptr<KeyframeDetection> PngFolderDetection(const std::string& folder, int w, int h, double f,
                                                      std::optional<BackgroundOptions> refine = std::nullopt) {
  SegmenterOptions o;
  o.kind = "png-folder";
  o.png_folder = folder;
  const Camera c{f, f, w / 2.0, h / 2.0, w, h};
  return std::make_unique<KeyframeDetection>(o, c, 1, refine);
}

struct Fixture {
  std::string folder;
  std::unique_ptr<KeyframeDetection> detection;
  std::vector<uint8_t> rgb = std::vector<uint8_t>(kW * kH * 3, 90);

  Fixture() {
    folder = testing::TestTempDir();
    detection = PngFolderDetection(folder, kW, kH, 20);
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

// A 40x30 frame: a wall at 2 m and a person at 1 m in columns 14-23; the
// segmentation's box spills onto the wall (columns 6-31).
struct RefineFixture {
  static constexpr int kW2 = 40, kH2 = 30;
  std::string folder;
  std::unique_ptr<KeyframeDetection> detection;
  std::vector<uint8_t> rgb = std::vector<uint8_t>(kW2 * kH2 * 3, 90);
  cv::Mat depth = cv::Mat(kH2, kW2, CV_32FC1, cv::Scalar(2.0f));
  cv::Mat background = cv::Mat(kH2, kW2, CV_32FC1, cv::Scalar(2.0f));  // B: the wall everywhere
  cv::Mat support = cv::Mat(kH2, kW2, CV_8UC1, cv::Scalar(10));

  explicit RefineFixture(bool refine) {
    folder = testing::TestTempDir() + "/refine";
    std::filesystem::create_directories(folder);
    detection = PngFolderDetection(folder, kW2, kH2, 40,
                                   refine ? std::optional<BackgroundOptions>(BackgroundOptions()) : std::nullopt);
    depth.colRange(14, 24).setTo(1.0f);
    cv::Mat box(kH2, kW2, CV_8UC1, cv::Scalar(0));
    box.colRange(6, 32).setTo(255);
    cv::imwrite(folder + "/k.png", box);
  }
  cv::Mat Ask(int t) {
    KeyframeMaskRequest r;
    r.timestamp = t;
    r.width = kW2;
    r.height = kH2;
    r.rgb = rgb.data();
    r.depth_m = depth.ptr<float>();
    const std::vector<uint8_t> m = (*detection)(r);
    EXPECT_EQ(m.size(), static_cast<size_t>(kW2 * kH2));
    return cv::Mat(kH2, kW2, CV_8UC1, const_cast<uint8_t*>(m.data())).clone();
  }
};

TEST(KeyframeDetection, TheFreshMaskIsRefinedByTheFramesBackground) {
  RefineFixture f(true);
  f.detection->Note(1, "k", false, f.background, f.support);
  const cv::Mat m = f.Ask(1);
  EXPECT_EQ(cv::countNonZero(m.colRange(14, 24)), 10 * 30) << "the person stays";
  EXPECT_EQ(cv::countNonZero(m.colRange(0, 11)), 0) << "the wall beside him is static";
  EXPECT_EQ(cv::countNonZero(m.colRange(27, 40)), 0);
  EXPECT_EQ(f.detection->refined(), 1);
  EXPECT_GE(f.detection->refined_pixels(), 2 * 5 * 30);
  // A background seen too few times (a person missed since the start can
  // be "background"): the box stays whole.
  f.support.setTo(BackgroundOptions().min_support - 1);
  f.detection->Note(2, "k", false, f.background, f.support);
  EXPECT_EQ(cv::countNonZero(f.Ask(2).colRange(6, 32)), 26 * 30);
  // No background given, or the frame's background no longer kept.
  f.detection->Note(3, "k", false);
  EXPECT_EQ(cv::countNonZero(f.Ask(3).colRange(6, 32)), 26 * 30);
  f.support.setTo(10);
  f.detection->Note(4, "k", false, f.background, f.support);
  f.detection->Claim(4);
  for (int t = 5; t < 5 + static_cast<int>(KeyframeDetection::kBackgroundFrames); ++t)
    f.detection->Note(t, "k", false, f.background, f.support);
  EXPECT_EQ(cv::countNonZero(f.Ask(4).colRange(0, 11)), 0) << "claimed: its background is kept";
  f.detection->Note(100, "k", false, f.background, f.support);
  for (int t = 101; t < 101 + static_cast<int>(KeyframeDetection::kBackgroundFrames); ++t)
    f.detection->Note(t, "k", false);
  EXPECT_EQ(cv::countNonZero(f.Ask(100).colRange(6, 32)), 26 * 30) << "unclaimed and older than the kept backgrounds";
  EXPECT_EQ(f.detection->refined(), 3);  // frames 1, 2 (nothing made static) and 4
  EXPECT_INVALID_INPUT(f.detection->Note(200, "k", false, f.support, f.support), "CV_32FC1");
}

TEST(KeyframeDetection, WithoutRefinementTheFreshMaskIsTheSegmentation) {
  RefineFixture f(false);
  f.detection->Note(1, "k", false, f.background, f.support);
  EXPECT_EQ(cv::countNonZero(f.Ask(1).colRange(6, 32)), 26 * 30);
  EXPECT_EQ(cv::countNonZero(f.Ask(1)), 26 * 30);
  EXPECT_EQ(f.detection->refined(), 0);
}

}  // namespace
}  // namespace dypho
