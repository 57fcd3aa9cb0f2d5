// Keyframe selection (engine/map/keyframe_selector.h) on scenes with known
// answers: the new-content fraction of a sideways move over a wall, content
// appearing in front, pixels without depth, the motion and gap rules, the
// sharpness window, and the end of a sequence (its tail candidate).
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "engine/map/keyframe_selector.h"
#include "tests/test_data.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

const Camera kCamera{500, 500, 319.5, 239.5, 640, 480};

// A fronto-parallel wall at z = `wall` metres (camera looking along +z).
ImageF Wall(float wall) { return ImageF(640, 480, 1, wall); }

// A textured colour image (a checkerboard of 16 px cells), blurred when asked.
ImageU8 Texture(double blur_sigma) {
  ImageU8 rgb(640, 480, 3);
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 640; ++x) {
      const uint8_t v = ((x / 16 + y / 16) % 2) ? 220 : 30;
      for (int c = 0; c < 3; ++c) rgb.data()[(y * 640 + x) * 3 + c] = v;
    }
  }
  if (blur_sigma > 0) {
    cv::Mat m = CvView(rgb);
    cv::GaussianBlur(m.clone(), m, cv::Size(0, 0), blur_sigma);
  }
  return rgb;
}

// The camera moved sideways by `dx` metres (world x).
Rigid3d Sideways(double dx) { return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-dx, 0, 0)); }

KeyframePolicy Policy() {
  KeyframePolicy p;
  p.max_translation = 100.0;  // motion rules out of the way
  p.max_rotation_deg = 179.0;
  p.max_frame_gap = 1000;
  p.min_new_content = 0.2;
  p.sharpness_window = 1;
  return p;
}

TEST(KeyframeSelector, NewContentIsTheFractionOfTheViewNoKeyframeSaw) {
  KeyframeSelector s(Policy(), kCamera);
  const ImageU8 rgb = Texture(0);
  const KeyframeDecision first = s.Offer(Sideways(0), Wall(2.0f), rgb, ImageU8());
  EXPECT_TRUE(first.keep && first.emit);
  // At 2 m the view is 640 * 2 / 500 = 2.56 m wide: a move of 0.384 m
  // brings 15% new wall into view; 0.64 m brings 25%.
  const KeyframeDecision small = s.Offer(Sideways(0.384), Wall(2.0f), rgb, ImageU8());
  EXPECT_NEAR(small.new_content, 0.15, 0.02);
  EXPECT_FALSE(small.emit);
  const KeyframeDecision large = s.Offer(Sideways(0.64), Wall(2.0f), rgb, ImageU8());
  EXPECT_NEAR(large.new_content, 0.25, 0.02);
  EXPECT_TRUE(large.emit);
  EXPECT_EQ(s.num_keyframes(), 2);
  // Back to the start: both keyframes explain everything.
  EXPECT_NEAR(s.Offer(Sideways(0.3), Wall(2.0f), rgb, ImageU8()).new_content, 0.0, 0.01);
}

TEST(KeyframeSelector, ContentInFrontOfTheKeyframesSurfaceIsNew) {
  KeyframeSelector s(Policy(), kCamera);
  const ImageU8 rgb = Texture(0);
  s.Offer(Sideways(0), Wall(3.0f), rgb, ImageU8());
  // A box at 1.5 m covers the left half of the view: the keyframe saw the
  // wall behind it there (free space), so that half is new.
  ImageF depth = Wall(3.0f);
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 320; ++x) depth.data()[y * 640 + x] = 1.5f;
  }
  EXPECT_NEAR(s.Offer(Sideways(0), depth, rgb, ImageU8()).new_content, 0.5, 0.02);
  // The same box marked dynamic: it is not content of the map.
  ImageU8 mask(640, 480, 1, 0);
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 320; ++x) mask.data()[y * 640 + x] = 255;
  }
  EXPECT_NEAR(s.Offer(Sideways(0), depth, rgb, mask).new_content, 0.0, 0.01);
}

TEST(KeyframeSelector, PixelsWithoutDepthAreNewWhereNoKeyframeLooked) {
  KeyframeSelector s(Policy(), kCamera);
  const ImageU8 rgb = Texture(0);
  // The first keyframe cannot measure the left half of the wall.
  ImageF left_unmeasured = Wall(2.0f);
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 320; ++x) left_unmeasured.data()[y * 640 + x] = 0.0f;
  }
  EXPECT_TRUE(s.Offer(Sideways(0), left_unmeasured, rgb, ImageU8()).emit);
  // The same view again: its pixels without depth were looked at.
  EXPECT_NEAR(s.Offer(Sideways(0), left_unmeasured, rgb, ImageU8()).new_content, 0.0, 0.01);
  // After a keyframe that measured the whole wall, a move of 0.64 m brings
  // the right quarter of the view (columns 480 on, see
  // NewContentIsTheFractionOfTheViewNoKeyframeSaw) into view; it has no
  // depth: all the depth is explained, but a quarter of the view is new.
  KeyframeSelector t(Policy(), kCamera);
  t.Offer(Sideways(0), Wall(2.0f), rgb, ImageU8());
  ImageF right_unmeasured = Wall(2.0f);
  for (int y = 0; y < 480; ++y) {
    for (int x = 480; x < 640; ++x) right_unmeasured.data()[y * 640 + x] = 0.0f;
  }
  // Marked dynamic, those pixels are not content of the map.
  ImageU8 mask(640, 480, 1, 0);
  for (int y = 0; y < 480; ++y) {
    for (int x = 480; x < 640; ++x) mask.data()[y * 640 + x] = 255;
  }
  EXPECT_NEAR(t.Offer(Sideways(0.64), right_unmeasured, rgb, mask).new_content, 0.0, 0.01);
  const KeyframeDecision d = t.Offer(Sideways(0.64), right_unmeasured, rgb, ImageU8());
  EXPECT_NEAR(d.new_content, 0.25, 0.02);
  EXPECT_TRUE(d.emit);
}

TEST(KeyframeSelector, TheEndOfASequenceKeepsItsNewContent) {
  const ImageU8 rgb = Texture(0);
  for (const double tail : {0.02, 0.0}) {
    KeyframePolicy p = Policy();  // min_new_content 0.2
    p.tail_new_content = tail;
    KeyframeSelector s(p, kCamera);
    s.Offer(Sideways(0), Wall(2.0f), rgb, ImageU8());
    // 10 % new: not due, but the tail candidate (0.256 m of a 2.56 m view).
    const KeyframeDecision d = s.Offer(Sideways(0.256), Wall(2.0f), rgb, ImageU8());
    EXPECT_NEAR(d.new_content, 0.10, 0.02);
    EXPECT_FALSE(d.emit);
    EXPECT_EQ(d.keep, tail > 0);
    // A later frame with nothing new does not replace it.
    EXPECT_FALSE(s.Offer(Sideways(0.0), Wall(2.0f), rgb, ImageU8()).keep);
    EXPECT_EQ(s.pending(), tail > 0);
    EXPECT_EQ(s.Flush(), tail > 0);
    EXPECT_EQ(s.num_keyframes(), tail > 0 ? 2 : 1);
    EXPECT_FALSE(s.pending());
    if (tail == 0) continue;
    // The tail keyframe is frame 1's view.
    EXPECT_NEAR(s.Offer(Sideways(0.256), Wall(2.0f), rgb, ImageU8()).new_content, 0.0, 0.01);
  }
  // A newer frame with new content replaces the tail candidate (window 1).
  KeyframeSelector s(Policy(), kCamera);
  s.Offer(Sideways(0), Wall(2.0f), rgb, ImageU8());
  EXPECT_TRUE(s.Offer(Sideways(0.256), Wall(2.0f), rgb, ImageU8()).keep);
  EXPECT_TRUE(s.Offer(Sideways(-0.256), Wall(2.0f), rgb, ImageU8()).keep);
  EXPECT_TRUE(s.Flush());
  EXPECT_NEAR(s.Offer(Sideways(-0.256), Wall(2.0f), rgb, ImageU8()).new_content, 0.0, 0.01);
  EXPECT_NEAR(s.Offer(Sideways(0.256), Wall(2.0f), rgb, ImageU8()).new_content, 0.10, 0.02);
  // A window opening replaces it with its own candidate.
  KeyframeSelector w(Policy(), kCamera);
  w.Offer(Sideways(0), Wall(2.0f), rgb, ImageU8());
  EXPECT_TRUE(w.Offer(Sideways(0.256), Wall(2.0f), rgb, ImageU8()).keep);
  const KeyframeDecision due = w.Offer(Sideways(-0.64), Wall(2.0f), rgb, ImageU8());
  EXPECT_TRUE(due.keep && due.emit);
  EXPECT_FALSE(w.Flush());
  EXPECT_EQ(w.num_keyframes(), 2);
}

TEST(KeyframeSelector, MotionAndGapRules) {
  KeyframePolicy p = Policy();
  p.min_new_content = 0;  // pose rules only
  p.max_translation = 0.1;
  p.max_rotation_deg = 10;
  p.max_frame_gap = 5;
  KeyframeSelector s(p, kCamera);
  const ImageU8 rgb = Texture(0);
  EXPECT_TRUE(s.Offer(Sideways(0), Wall(2), rgb, ImageU8()).emit);
  EXPECT_FALSE(s.Offer(Sideways(0.05), Wall(2), rgb, ImageU8()).emit);
  EXPECT_TRUE(s.Offer(Sideways(0.15), Wall(2), rgb, ImageU8()).emit);
  const Rigid3d turned(Eigen::Quaterniond(Eigen::AngleAxisd(12 * M_PI / 180, Eigen::Vector3d::UnitY())),
                       Sideways(0.15).translation);
  EXPECT_TRUE(s.Offer(turned, Wall(2), rgb, ImageU8()).emit);
  int emitted_at = -1;
  for (int i = 1; i <= 5; ++i) {
    if (s.Offer(turned, Wall(2), rgb, ImageU8()).emit) emitted_at = i;
  }
  EXPECT_EQ(emitted_at, 5);  // the gap rule
  // A frame without depth is never a keyframe.
  EXPECT_FALSE(s.Offer(Sideways(5), ImageF(), rgb, ImageU8()).emit);
}

TEST(KeyframeSelector, TheSharpestFrameOfTheWindowBecomesTheKeyframe) {
  KeyframePolicy p = Policy();
  p.sharpness_window = 4;
  KeyframeSelector s(p, kCamera);
  const ImageU8 sharp = Texture(0), soft = Texture(2.0), softer = Texture(4.0);
  EXPECT_GT(ImageSharpness(sharp, ImageU8()), 2 * ImageSharpness(soft, ImageU8()));
  EXPECT_GT(ImageSharpness(soft, ImageU8()), ImageSharpness(softer, ImageU8()));
  // Frames 0..3: soft, sharp, softer, soft: keep 0, keep 1, emit (frame 1) at 3.
  KeyframeDecision d = s.Offer(Sideways(0), Wall(2), soft, ImageU8());
  EXPECT_TRUE(d.keep);
  EXPECT_FALSE(d.emit);
  d = s.Offer(Sideways(0.01), Wall(2), sharp, ImageU8());
  EXPECT_TRUE(d.keep);
  EXPECT_FALSE(d.emit);
  d = s.Offer(Sideways(0.02), Wall(2), softer, ImageU8());
  EXPECT_FALSE(d.keep);
  EXPECT_TRUE(s.pending());
  d = s.Offer(Sideways(0.03), Wall(2), soft, ImageU8());
  EXPECT_FALSE(d.keep);
  EXPECT_TRUE(d.emit);
  EXPECT_FALSE(s.pending());
  // The keyframe is frame 1's view: a frame there has nothing new.
  EXPECT_NEAR(s.Offer(Sideways(0.01), Wall(2), sharp, ImageU8()).new_content, 0.0, 0.01);
  // A window left open at the end of the sequence: Flush emits its candidate.
  s.Offer(Sideways(1.5), Wall(2), sharp, ImageU8());
  EXPECT_TRUE(s.pending());
  EXPECT_TRUE(s.Flush());
  EXPECT_FALSE(s.Flush());
  EXPECT_EQ(s.num_keyframes(), 2);
}

TEST(KeyframeSelector, BadPolicyAndSizesAreClearErrors) {
  KeyframePolicy p = Policy();
  p.min_new_content = 1.5;
  EXPECT_INVALID_INPUT(KeyframeSelector(p, kCamera), "min_new_content");
  p = Policy();
  p.sharpness_window = 0;
  EXPECT_INVALID_INPUT(KeyframeSelector(p, kCamera), "sharpness_window");
  KeyframeSelector s(Policy(), kCamera);
  EXPECT_INVALID_INPUT(s.Offer(Rigid3d(), ImageF(320, 240, 1, 1.0f), ImageU8(), ImageU8()), "320x240");
}

}  // namespace
}  // namespace dypho
