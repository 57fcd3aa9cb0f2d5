// Tests of the semantic prior (masking/segmenter.h and its implementations):
// YOLOv8-seg decoding on synthetic output tensors with known answers, masks
// from depth inside boxes, the PNG-folder segmenter, clear errors for bad
// models and inputs. YOLOX: masking_yolox_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "common/check.h"
#include "masking/coco_classes.h"
#include "masking/depth_box_mask.h"
#include "masking/dnn_model.h"
#include "masking/dynamic_masker.h"
#include "masking/png_folder_segmenter.h"
#include "masking/segmenter.h"
#include "masking/yolov8_seg.h"
#include "tests/onnx_bytes.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

double Fraction(const cv::Mat& mask, const cv::Rect& region) {
  return static_cast<double>(cv::countNonZero(mask(region))) / region.area();
}

double MaskIou(const cv::Mat& a, const cv::Mat& b) {
  const double inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni > 0 ? inter / uni : 1.0;
}

// ---------------------------------------------------------------------------
// A valid ONNX model with the wrong output shape: one Flatten node from
// "images" (1x3x416x416) to "output" (1x519168).

std::string FlattenModel() {
  return testing::OnnxModel({testing::OnnxNode("Flatten", {"images"}, {"output"}, "flatten")}, {}, {1, 3, 416, 416},
                            {1, 3 * 416 * 416});
}
// ---------------------------------------------------------------------------
// Classes and options

TEST(MaskingClasses, ParsesNamesAndTheMovingSet) {
  EXPECT_EQ(CocoClassNames().size(), 80u);
  EXPECT_EQ(CocoClassId("person"), 0);
  EXPECT_EQ(CocoClassId("boat"), 8);
  EXPECT_EQ(CocoClassId("dog"), 16);
  EXPECT_EQ(CocoClassId("unicorn"), -1);
  EXPECT_EQ(ParseClassList("person, dog,boat"), (std::vector<std::string>{"person", "dog", "boat"}));
  const std::vector<std::string> moving = ParseClassList("moving");
  EXPECT_EQ(moving, MovingCocoClasses());
  for (const char* c : {"person", "car", "boat", "horse", "bird", "truck", "bicycle"})
    EXPECT_NE(std::find(moving.begin(), moving.end(), c), moving.end()) << c;
  for (const char* c : {"chair", "tv", "dining table", "potted plant"})
    EXPECT_EQ(std::find(moving.begin(), moving.end(), c), moving.end()) << c;
  EXPECT_INVALID_INPUT(ParseClassList("person,unicorn"), "unicorn");
}

TEST(MaskingSegmenterOptions, IsValidNamesTheField) {
  std::string error;
  EXPECT_TRUE(SegmenterOptions().IsValid(&error)) << error;
  SegmenterOptions o;
  o.score_threshold = 1.5;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("score_threshold"), std::string::npos) << error;
  o = SegmenterOptions();
  o.classes = {"person", "dragon"};
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("dragon"), std::string::npos) << error;
  o = SegmenterOptions();
  o.box_mask.bin_size = 0.0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("box_mask.bin_size"), std::string::npos) << error;
  o = SegmenterOptions();
  o.enclosing_score_ratio = 2.0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("enclosing_score_ratio"), std::string::npos) << error;
  o = SegmenterOptions();
  o.kind = "yolox";
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("model_path"), std::string::npos) << error;
  o.kind = "maskrcnn";
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("kind"), std::string::npos) << error;
  MaskingOptions m;
  m.flow.scale = 0.0;
  EXPECT_FALSE(m.IsValid(&error));
  EXPECT_NE(error.find("flow.scale"), std::string::npos) << error;
  m = MaskingOptions();
  m.background.window_radius_px = 0;
  EXPECT_FALSE(m.IsValid(&error));
  EXPECT_NE(error.find("background.window_radius_px"), std::string::npos) << error;
  m = MaskingOptions();
  m.epipolar.lk_window_px = 20;
  EXPECT_FALSE(m.IsValid(&error));
  EXPECT_NE(error.find("epipolar.lk_window_px"), std::string::npos) << error;
  m = MaskingOptions();
  m.shore.scale = 2.0;
  EXPECT_FALSE(m.IsValid(&error));
  EXPECT_NE(error.find("shore.scale"), std::string::npos) << error;
  m = MaskingOptions();
  m.schedule.interval = 0;
  EXPECT_FALSE(m.IsValid(&error));
  EXPECT_NE(error.find("schedule.interval"), std::string::npos) << error;
}

// ---------------------------------------------------------------------------
// Letterbox

TEST(MaskingLetterbox, MapsInputPixelsBackToTheImage) {
  const Letterbox top_left = Letterbox::Make({640, 480}, {416, 416}, false);
  EXPECT_DOUBLE_EQ(top_left.scale, 0.65);
  EXPECT_DOUBLE_EQ(top_left.pad_x, 0.0);
  EXPECT_DOUBLE_EQ(top_left.pad_y, 0.0);
  EXPECT_NEAR(top_left.ToImage({416, 312}).x, 640.0, 1e-9);
  EXPECT_NEAR(top_left.ToImage({416, 312}).y, 480.0, 1e-9);
  const Letterbox centred = Letterbox::Make({640, 480}, {640, 640}, true);
  EXPECT_DOUBLE_EQ(centred.scale, 1.0);
  EXPECT_DOUBLE_EQ(centred.pad_y, 80.0);
  EXPECT_NEAR(centred.ToImage({100, 180}).y, 100.0, 1e-9);
  // The blob holds the scaled image at the offset and the pad value elsewhere, in BGR order.
  cv::Mat rgb(480, 640, CV_8UC3, cv::Scalar(10, 20, 30));
  const cv::Mat blob = MakeLetterboxBlob(rgb, centred, /*bgr=*/true, 1.0, 114.0);
  ASSERT_EQ(blob.dims, 4);
  EXPECT_EQ(blob.size[1], 3);
  auto at = [&](int c, int y, int x) { return blob.ptr<float>(0, c)[y * 640 + x]; };
  EXPECT_FLOAT_EQ(at(0, 10, 10), 114.0f);   // pad
  EXPECT_FLOAT_EQ(at(0, 300, 300), 30.0f);  // B
  EXPECT_FLOAT_EQ(at(2, 300, 300), 10.0f);  // R
}

// ---------------------------------------------------------------------------
// YOLOv8-seg decoding

struct Yolov8Case {
  cv::Mat detections;  // 1 x 116 x N (channels first) or 1 x N x 116
  cv::Mat prototypes;  // 1 x 32 x 160 x 160
};

// Two instances on a 640x640 input: prototype channel 0 is +8 inside a disc of
// radius 20 (prototype px) around (50, 75) and -8 outside; channel 5 is +8 in
// the rectangle [100, 140) x [20, 60) and -8 outside. Detection A (person,
// 0.9) has box centre (200, 300), size 100 x 200 (input px) and coefficient 1
// on channel 0; detection B (dog, 0.8) box (480, 160) size 200 x 200 and
// coefficient 1 on channel 5; a third anchor is a low-score person.
Yolov8Case MakeYolov8Case(bool channels_first) {
  const int n = 9;
  const int c = 4 + 80 + 32;
  Yolov8Case out;
  const int proto_sizes[4] = {1, 32, 160, 160};
  out.prototypes = cv::Mat(4, proto_sizes, CV_32F, cv::Scalar(0));
  auto proto = [&](int k, int y, int x) -> float& { return out.prototypes.ptr<float>(0, k)[y * 160 + x]; };
  for (int y = 0; y < 160; ++y) {
    for (int x = 0; x < 160; ++x) {
      proto(0, y, x) = std::hypot(x - 50.0, y - 75.0) < 20.0 ? 8.0f : -8.0f;
      proto(5, y, x) = (x >= 100 && x < 140 && y >= 20 && y < 60) ? 8.0f : -8.0f;
    }
  }
  const int det_sizes[3] = {1, channels_first ? c : n, channels_first ? n : c};
  out.detections = cv::Mat(3, det_sizes, CV_32F, cv::Scalar(0));
  auto at = [&](int channel, int anchor) -> float& {
    float* d = out.detections.ptr<float>(0);
    return channels_first ? d[channel * n + anchor] : d[anchor * c + channel];
  };
  auto set = [&](int anchor, float cx, float cy, float w, float h, int cls, float score, int coefficient) {
    at(0, anchor) = cx, at(1, anchor) = cy, at(2, anchor) = w, at(3, anchor) = h;
    at(4 + cls, anchor) = score;
    at(84 + coefficient, anchor) = 1.0f;
  };
  set(2, 200, 300, 100, 200, 0, 0.9f, 0);
  set(5, 480, 160, 200, 200, 16, 0.8f, 5);
  set(7, 100, 100, 50, 50, 0, 0.1f, 0);
  return out;
}

// Expected mask of detection A in image pixels (input = image + (0, pad_y)):
// the disc of radius 80 around input (200, 300) inside the box [150, 250] x [200, 400].
cv::Mat ExpectedDisc(const cv::Size& image, double pad_y) {
  cv::Mat m(image, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const double ix = x + 0.5, iy = y + 0.5 + pad_y;
      const bool in_box = ix >= 150 && ix <= 250 && iy >= 200 && iy <= 400;
      if (in_box && std::hypot(ix - 200.0, iy - 300.0) < 80.0) m.at<uint8_t>(y, x) = 255;
    }
  }
  return m;
}

cv::Mat Paint(const Detection& d, const cv::Size& image) {
  cv::Mat m(image, CV_8UC1, cv::Scalar(0));
  if (!d.mask_roi.empty()) d.mask.copyTo(m(d.mask_roi));
  return m;
}

TEST(MaskingYolov8Seg, DecodesMasksFromPrototypesWithAKnownAnswer) {
  for (bool channels_first : {true, false}) {
    SCOPED_TRACE(channels_first ? "1x116xN" : "1xNx116");
    const Yolov8Case c = MakeYolov8Case(channels_first);
    const cv::Size image(640, 640);
    const Letterbox lb = Letterbox::Make(image, {640, 640}, true);
    const std::vector<Detection> dets =
        DecodeYolov8SegOutput(c.detections, c.prototypes, lb, image, {0, 16}, 0.25, 0.45, 0.5);
    ASSERT_EQ(dets.size(), 2u);
    EXPECT_EQ(dets[0].class_id, 0);
    EXPECT_NEAR(dets[0].score, 0.9f, 1e-6);
    EXPECT_NEAR(dets[0].box.x, 150.0f, 1e-3);
    EXPECT_NEAR(dets[0].box.height, 200.0f, 1e-3);
    EXPECT_GT(MaskIou(Paint(dets[0], image), ExpectedDisc(image, 0.0)), 0.95);
    // B: the rectangle [400, 560) x [80, 240) (prototype px x 4) inside its box [380, 580] x [60, 260].
    EXPECT_EQ(dets[1].class_id, 16);
    cv::Mat expected_b(image, CV_8UC1, cv::Scalar(0));
    expected_b(cv::Rect(400, 80, 160, 160)).setTo(255);
    EXPECT_GT(MaskIou(Paint(dets[1], image), expected_b), 0.95);
    // Only people: the dog goes.
    EXPECT_EQ(DecodeYolov8SegOutput(c.detections, c.prototypes, lb, image, {0}, 0.25, 0.45, 0.5).size(), 1u);
  }
}

TEST(MaskingYolov8Seg, UndoesTheLetterboxForAWideImage) {
  const Yolov8Case c = MakeYolov8Case(true);
  const cv::Size image(640, 480);  // letterboxed into 640x640 with 80 px of pad on top
  const Letterbox lb = Letterbox::Make(image, {640, 640}, true);
  ASSERT_DOUBLE_EQ(lb.pad_y, 80.0);
  const std::vector<Detection> dets =
      DecodeYolov8SegOutput(c.detections, c.prototypes, lb, image, {0}, 0.25, 0.45, 0.5);
  ASSERT_EQ(dets.size(), 1u);
  EXPECT_NEAR(dets[0].box.y, 120.0f, 1e-3);
  EXPECT_GT(MaskIou(Paint(dets[0], image), ExpectedDisc(image, 80.0)), 0.95);
}

TEST(MaskingYolov8Seg, RejectsShapesThatDoNotFit) {
  const Yolov8Case c = MakeYolov8Case(true);
  const Letterbox lb = Letterbox::Make({640, 640}, {640, 640}, true);
  const int flat[2] = {116, 9};
  EXPECT_INVALID_INPUT(DecodeYolov8SegOutput(cv::Mat(2, flat, CV_32F, cv::Scalar(0)), c.prototypes, lb, {640, 640}, {0},
                                             0.25, 0.45, 0.5),
                       "detections");
  const int small[3] = {1, 20, 9};  // 20 channels cannot hold 4 + classes + 32
  EXPECT_INVALID_INPUT(DecodeYolov8SegOutput(cv::Mat(3, small, CV_32F, cv::Scalar(0)), c.prototypes, lb, {640, 640},
                                             {0}, 0.25, 0.45, 0.5),
                       "do not fit");
}

// ---------------------------------------------------------------------------
// Mask from depth inside a box

struct BoxScene {
  cv::Mat depth;   // [m]
  cv::Mat object;  // true object pixels
  cv::Rect box;    // a detector's box around the object
  cv::Rect desk;   // nearer content inside the box
};

// A wall at 4 m with a floor rising into the bottom rows, a person-like
// figure (head disc, torso, legs) at 2.0-2.3 m, and a desk edge at 1.5 m
// entering the box at the lower right.
BoxScene MakeBoxScene() {
  BoxScene s;
  s.depth = cv::Mat(240, 320, CV_32F, cv::Scalar(4.0f));
  for (int y = 180; y < 240; ++y) s.depth.row(y).setTo(4.0f - (y - 180) * 0.03f);  // floor towards the camera
  s.object = cv::Mat(240, 320, CV_8UC1, cv::Scalar(0));
  cv::circle(s.object, {150, 60}, 16, 255, -1);
  cv::rectangle(s.object, cv::Rect(125, 76, 50, 80), 255, -1);
  cv::rectangle(s.object, cv::Rect(128, 156, 18, 70), 255, -1);
  cv::rectangle(s.object, cv::Rect(154, 156, 18, 70), 255, -1);
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x)
      if (s.object.at<uint8_t>(y, x)) s.depth.at<float>(y, x) = 2.0f + 0.3f * (y - 44) / 180.0f;  // slanted
  s.desk = cv::Rect(168, 170, 60, 70);
  s.depth(s.desk).setTo(1.5f);
  s.object(s.desk).setTo(0);
  // Sensor holes: a few inside the person, one in the wall.
  s.depth(cv::Rect(140, 100, 6, 6)).setTo(0.0f);
  s.depth(cv::Rect(60, 30, 10, 10)).setTo(0.0f);
  s.box = cv::Rect(118, 40, 66, 190);
  return s;
}

// The fraction of `r` that a box mask, painted into an image of `size`, covers.
double PaintedFraction(const BoxMask& m, const cv::Size& size, const cv::Rect& r) {
  cv::Mat painted(size, CV_8UC1, cv::Scalar(0));
  m.mask.copyTo(painted(m.roi));
  return static_cast<double>(cv::countNonZero(painted(r))) / r.area();
}

TEST(MaskingDepthBoxMask, FindsTheConnectedRegionAtTheDominantForegroundDepth) {
  const BoxScene s = MakeBoxScene();
  const BoxMask bm = MaskFromDepthInBox(s.depth, s.box, DepthBoxMaskOptions());
  ASSERT_TRUE(bm.from_depth);
  EXPECT_NEAR(bm.depth, 2.15f, 0.1f);
  cv::Mat painted(s.depth.size(), CV_8UC1, cv::Scalar(0));
  bm.mask.copyTo(painted(bm.roi));
  const cv::Mat truth = s.object & cv::Mat(s.object.size(), CV_8UC1, cv::Scalar(0));
  cv::Mat truth_in_box(s.depth.size(), CV_8UC1, cv::Scalar(0));
  s.object(s.box).copyTo(truth_in_box(s.box));
  EXPECT_GT(MaskIou(painted, truth_in_box), 0.9);
  EXPECT_LT(Fraction(painted, s.desk & s.box), 0.05);                // the nearer desk is not the person
  EXPECT_EQ(painted.at<uint8_t>(103, 143), 255);                     // the hole in the person is filled
  EXPECT_LT(Fraction(painted, cv::Rect(s.box.x, 40, 8, 10)), 0.05);  // wall corner of the box
}

// Two people, one partly behind the other (the walkers frames): the far
// person's box core is half filled by the near person, whose depth is the
// nearest large mode. Alone, the far box masks the near person again and
// leaves the far person's visible part unmasked; together, the far box finds
// its own person.
TEST(MaskingDepthBoxMask, APersonBehindAnotherFindsTheirOwnDepth) {
  cv::Mat depth(150, 200, CV_32F, cv::Scalar(4.0f));
  const cv::Rect near_person(60, 20, 80, 130), far_person(30, 30, 60, 120);
  depth(far_person).setTo(2.5f);
  depth(near_person).setTo(1.5f);
  const cv::Rect far_visible(30, 30, 30, 120);  // left of the near person
  const cv::Rect near_box(56, 16, 88, 134), far_box(26, 26, 64, 124);
  auto painted_fraction = [&](const BoxMask& m, const cv::Rect& r) { return PaintedFraction(m, depth.size(), r); };
  const BoxMask alone = MaskFromDepthInBox(depth, far_box, DepthBoxMaskOptions());
  EXPECT_NEAR(alone.depth, 1.5f, 0.1f);
  EXPECT_LT(painted_fraction(alone, far_visible), 0.1);
  const std::vector<BoxMask> both = MasksFromDepthInBoxes(depth, {near_box, far_box}, DepthBoxMaskOptions());
  ASSERT_EQ(both.size(), 2u);
  EXPECT_NEAR(both[0].depth, 1.5f, 0.1f);
  EXPECT_GT(painted_fraction(both[0], near_person), 0.95);
  EXPECT_NEAR(both[1].depth, 2.5f, 0.1f);
  EXPECT_GT(painted_fraction(both[1], far_visible), 0.95);
  // The order of the boxes does not matter.
  const std::vector<BoxMask> swapped = MasksFromDepthInBoxes(depth, {far_box, near_box}, DepthBoxMaskOptions());
  EXPECT_NEAR(swapped[0].depth, 2.5f, 0.1f);
  EXPECT_NEAR(swapped[1].depth, 1.5f, 0.1f);
  // Two people side by side are left as they are.
  cv::Mat apart(150, 200, CV_32F, cv::Scalar(4.0f));
  apart(cv::Rect(10, 20, 50, 130)).setTo(2.0f);
  apart(cv::Rect(120, 20, 50, 130)).setTo(2.0f);
  const std::vector<BoxMask> side = MasksFromDepthInBoxes(apart, {cv::Rect(5, 15, 60, 135), cv::Rect(115, 15, 60, 135)},
                                                          DepthBoxMaskOptions());
  EXPECT_NEAR(side[0].depth, 2.0f, 0.1f);
  EXPECT_NEAR(side[1].depth, 2.0f, 0.1f);
}

// A person standing behind a desk (the walkers frames): the desk fills the
// lower part of the box core and is its nearest large mode. By default the
// desk is taken; with min_box_iou the desk's region covers too little of
// the box and the person's depth, whose region covers more, is taken.
TEST(MaskingDepthBoxMask, APersonBehindADeskWithMinBoxIou) {
  cv::Mat depth(160, 240, CV_32F, cv::Scalar(4.0f));
  const cv::Rect person(100, 20, 40, 130), desk(80, 100, 100, 60);
  depth(person).setTo(2.0f);
  depth(desk).setTo(1.2f);
  const cv::Rect visible(100, 20, 40, 80);  // the person above the desk
  const cv::Rect box(96, 16, 48, 130);
  auto painted_fraction = [&](const BoxMask& m, const cv::Rect& r) { return PaintedFraction(m, depth.size(), r); };
  const BoxMask nearest = MaskFromDepthInBox(depth, box, DepthBoxMaskOptions());
  EXPECT_NEAR(nearest.depth, 1.2f, 0.1f);
  EXPECT_LT(painted_fraction(nearest, visible), 0.1);
  DepthBoxMaskOptions o;
  o.min_box_iou = 0.9;
  const BoxMask m = MaskFromDepthInBox(depth, box, o);
  EXPECT_NEAR(m.depth, 2.0f, 0.1f);
  EXPECT_GT(painted_fraction(m, visible), 0.95);
  EXPECT_LT(painted_fraction(m, desk & box), 0.05);
  // A person in front of the desk stays the nearest mode's.
  cv::Mat front = depth.clone();
  front(person).setTo(0.9f);
  EXPECT_NEAR(MaskFromDepthInBox(front, box, o).depth, 0.9f, 0.1f);
  // A thin person in front of a wall, with slack in the box: the person's
  // region covers less than 0.9 of the box and the wall (a large mode of
  // the core) would cover all of it, but the wall lies around the person.
  cv::Mat wall(160, 240, CV_32F, cv::Scalar(3.0f));
  const cv::Rect thin(110, 20, 14, 130);
  wall(thin).setTo(1.5f);
  const BoxMask m_thin = MaskFromDepthInBox(wall, cv::Rect(100, 14, 34, 140), o);
  EXPECT_NEAR(m_thin.depth, 1.5f, 0.1f);
  EXPECT_GT(PaintedFraction(m_thin, wall.size(), thin), 0.95);
  o.min_box_iou = 1.5;
  EXPECT_INVALID_INPUT(MaskFromDepthInBox(depth, box, o), "min_box_iou");
}

// One box holding two people (the walkers frames: YOLOX boxes a near person
// and the strip of another half hidden behind them once): the depth region
// takes the near person only; with behind_min_height the far person's strip,
// touching the region and as tall as the box, joins it. A monitor beside the
// person (short) and a wall close behind a person (on both sides) do not.
TEST(MaskingDepthBoxMask, APersonBehindAnotherInTheSameBox) {
  cv::Mat depth(160, 240, CV_32F, cv::Scalar(3.0f));
  const cv::Rect far_person(70, 20, 50, 135), near_person(95, 15, 70, 145);
  depth(far_person).setTo(1.4f);
  depth(near_person).setTo(1.0f);
  const cv::Rect far_visible(70, 20, 25, 135);
  const cv::Rect box(66, 12, 102, 148);
  auto painted_fraction = [&](const BoxMask& m, const cv::Rect& r) { return PaintedFraction(m, depth.size(), r); };
  const BoxMask plain = MaskFromDepthInBox(depth, box, DepthBoxMaskOptions());
  EXPECT_NEAR(plain.depth, 1.0f, 0.1f);
  EXPECT_LT(painted_fraction(plain, far_visible), 0.1);
  DepthBoxMaskOptions o;
  o.behind_min_height = 0.6;
  const BoxMask m = MaskFromDepthInBox(depth, box, o);
  EXPECT_NEAR(m.depth, 1.0f, 0.1f);
  EXPECT_GT(painted_fraction(m, far_visible), 0.95);
  EXPECT_GT(painted_fraction(m, near_person & box), 0.95);
  EXPECT_LT(painted_fraction(m, cv::Rect(66, 12, 4, 148)), 0.05);  // the wall at the box's left edge
  // A monitor beside the person, a third of the box high: left out.
  cv::Mat monitor = cv::Mat(160, 240, CV_32F, cv::Scalar(3.0f));
  monitor(near_person).setTo(1.0f);
  const cv::Rect screen(70, 60, 25, 45);
  monitor(screen).setTo(1.4f);
  EXPECT_LT(PaintedFraction(MaskFromDepthInBox(monitor, box, o), monitor.size(), screen), 0.05);
  // A wall 0.4 m behind a person, on both sides of them: left out.
  cv::Mat wall(160, 240, CV_32F, cv::Scalar(1.4f));
  wall(near_person).setTo(1.0f);
  const BoxMask w = MaskFromDepthInBox(wall, box, o);
  EXPECT_LT(PaintedFraction(w, wall.size(), cv::Rect(70, 20, 25, 135)), 0.05);
  EXPECT_GT(PaintedFraction(w, wall.size(), near_person & box), 0.95);
  o.behind_min_height = -0.1;
  EXPECT_INVALID_INPUT(MaskFromDepthInBox(depth, box, o), "behind_min_height");
}

TEST(MaskingDepthBoxMask, FallsBackToTheWholeBoxWithoutDepth) {
  const BoxScene s = MakeBoxScene();
  const BoxMask none = MaskFromDepthInBox(cv::Mat(), s.box, DepthBoxMaskOptions());
  EXPECT_FALSE(none.from_depth);
  EXPECT_EQ(cv::countNonZero(none.mask), s.box.area());
  cv::Mat holes = s.depth.clone();
  holes(s.box).setTo(0.0f);
  const BoxMask empty = MaskFromDepthInBox(holes, s.box, DepthBoxMaskOptions());
  EXPECT_FALSE(empty.from_depth);
  EXPECT_EQ(cv::countNonZero(empty.mask), s.box.area());
  // whole_box: the whole box even where the depth would give a region.
  DepthBoxMaskOptions whole;
  whole.whole_box = true;
  const BoxMask all = MaskFromDepthInBox(s.depth, s.box, whole);
  EXPECT_FALSE(all.from_depth);
  EXPECT_EQ(cv::countNonZero(all.mask), s.box.area());
  // whole_box_border_px: only a box that reaches that close to the left or
  // right border is taken whole.
  DepthBoxMaskOptions border;
  border.whole_box_border_px = 4;
  EXPECT_TRUE(MaskFromDepthInBox(s.depth, s.box, border).from_depth);  // the scene's box is inside
  const cv::Rect at_right(s.depth.cols - s.box.width - 2, s.box.y, s.box.width, s.box.height);
  const BoxMask cut = MaskFromDepthInBox(s.depth, at_right, border);
  EXPECT_FALSE(cut.from_depth);
  EXPECT_EQ(cv::countNonZero(cut.mask), cut.roi.area());
  border.whole_box_border_px = -2;
  EXPECT_INVALID_INPUT(MaskFromDepthInBox(s.depth, s.box, border), "whole_box_border_px");
  // A box partly outside the image is clipped.
  const BoxMask clipped = MaskFromDepthInBox(s.depth, cv::Rect(300, 200, 50, 50), DepthBoxMaskOptions());
  EXPECT_EQ(clipped.roi, cv::Rect(300, 200, 20, 40));
  EXPECT_INVALID_INPUT(MaskFromDepthInBox(cv::Mat(10, 10, CV_16UC1), s.box, DepthBoxMaskOptions()), "depth");
}

// ---------------------------------------------------------------------------
// PNG folder, no segmenter, bad models

TEST(MaskingPngFolder, ReadsMasksByImageName) {
  const std::string dir = testing::TestTempDir();
  cv::Mat mask(48, 64, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(10, 5, 20, 30)).setTo(200);
  ASSERT_TRUE(cv::imwrite(dir + "/frame_001.png", mask));
  ASSERT_TRUE(cv::imwrite(dir + "/small.png", cv::Mat(10, 10, CV_8UC1, cv::Scalar(255))));
  SegmenterOptions o;
  o.png_folder = dir;
  const std::unique_ptr<Segmenter> seg = CreateSegmenter(o);
  EXPECT_EQ(seg->Name(), "png-folder");
  const cv::Mat rgb(48, 64, CV_8UC3, cv::Scalar(0, 0, 0));
  const Segmentation s = seg->Segment({rgb, cv::Mat(), "frame_001"});
  EXPECT_EQ(cv::countNonZero(s.mask), 600);
  EXPECT_EQ(s.mask.at<uint8_t>(6, 11), 255);
  EXPECT_INVALID_INPUT(seg->Segment({rgb, cv::Mat(), "frame_002"}), "frame_002.png");
  EXPECT_INVALID_INPUT(seg->Segment({rgb, cv::Mat(), "small"}), "small.png");
  EXPECT_INVALID_INPUT(seg->Segment({rgb, cv::Mat(), ""}), "name");
  o.png_missing_is_empty = true;
  EXPECT_EQ(cv::countNonZero(CreateSegmenter(o)->Segment({rgb, cv::Mat(), "frame_002"}).mask), 0);
  o.png_folder = dir + "/nope";
  EXPECT_INVALID_INPUT(CreateSegmenter(o), "nope");
}

// A full-resolution mask for an image downscaled by a whole factor (the
// pipeline's masking_downscale): a pixel is dynamic when any of its
// full-resolution pixels is; other sizes are an error naming the file.
TEST(MaskingPngFolder, FullResolutionMaskForADownscaledImage) {
  const std::string dir = testing::TestTempDir();
  cv::Mat mask(48, 64, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(10, 5, 20, 30)).setTo(255);  // x 10..29, y 5..34
  mask.at<uint8_t>(47, 63) = 255;            // one pixel in the last block
  ASSERT_TRUE(cv::imwrite(dir + "/f.png", mask));
  SegmenterOptions o;
  o.png_folder = dir;
  const std::unique_ptr<Segmenter> seg = CreateSegmenter(o);
  const Segmentation half = seg->Segment({cv::Mat(24, 32, CV_8UC3, cv::Scalar(0, 0, 0)), cv::Mat(), "f"});
  ASSERT_EQ(half.mask.size(), cv::Size(32, 24));
  // Blocks 2x2: x 5..14 (10 columns), y 2..17 (16 rows), plus (31, 23).
  EXPECT_EQ(cv::countNonZero(half.mask), 10 * 16 + 1);
  EXPECT_EQ(half.mask.at<uint8_t>(2, 5), 255);
  EXPECT_EQ(half.mask.at<uint8_t>(17, 14), 255);
  EXPECT_EQ(half.mask.at<uint8_t>(1, 5), 0);
  EXPECT_EQ(half.mask.at<uint8_t>(2, 15), 0);
  EXPECT_EQ(half.mask.at<uint8_t>(23, 31), 255);
  EXPECT_INVALID_INPUT(seg->Segment({cv::Mat(20, 30, CV_8UC3, cv::Scalar(0, 0, 0)), cv::Mat(), "f"}), "f.png");
}

TEST(MaskingSegmenter, WithoutAModelTheSemanticMaskIsEmpty) {
  const std::unique_ptr<Segmenter> seg = CreateSegmenter(SegmenterOptions());
  EXPECT_EQ(seg->Name(), "none");
  const Segmentation s = seg->Segment({cv::Mat(30, 40, CV_8UC3, cv::Scalar(1, 2, 3)), cv::Mat(), ""});
  EXPECT_EQ(s.mask.size(), cv::Size(40, 30));
  EXPECT_EQ(cv::countNonZero(s.mask), 0);
}

TEST(MaskingSegmenter, BadInputsGiveClearErrors) {
  const std::unique_ptr<Segmenter> seg = CreateSegmenter(SegmenterOptions());
  EXPECT_INVALID_INPUT(seg->Segment({cv::Mat(), cv::Mat(), ""}), "rgb is empty");
  EXPECT_INVALID_INPUT(seg->Segment({cv::Mat(30, 40, CV_8UC1), cv::Mat(), ""}), "rgb must be CV_8UC3");
  EXPECT_INVALID_INPUT(seg->Segment({cv::Mat(30, 40, CV_8UC3), cv::Mat(30, 41, CV_32FC1), ""}), "depth is 41x30");
  EXPECT_INVALID_INPUT(seg->Segment({cv::Mat(30, 40, CV_8UC3), cv::Mat(30, 40, CV_16UC1), ""}), "depth must be");
}

TEST(MaskingSegmenter, MissingUnreadableOrWronglyShapedModelsAreClearErrors) {
  const std::string dir = testing::TestTempDir();
  SegmenterOptions o;
  o.model_path = dir + "/missing.onnx";
  EXPECT_INVALID_INPUT(CreateSegmenter(o), "missing.onnx' does not exist");
  o.kind = "yolox";
  EXPECT_INVALID_INPUT(CreateSegmenter(o), "missing.onnx' does not exist");
  o.kind = "auto";
  testing::WriteBytes(dir + "/garbage.onnx", "this is not a protobuf");
  o.model_path = dir + "/garbage.onnx";
  EXPECT_INVALID_INPUT(CreateSegmenter(o), "cannot read ONNX model '" + o.model_path);
  // A valid ONNX model whose output is 1x519168 instead of 1x3549x85.
  testing::WriteBytes(dir + "/flatten.onnx", FlattenModel());
  o.model_path = dir + "/flatten.onnx";
  EXPECT_INVALID_INPUT(CreateSegmenter(o), "output shape 1x519168");
  o.kind = "yolov8-seg";
  EXPECT_INVALID_INPUT(CreateSegmenter(o), "has 1 outputs; YOLOv8-seg has two");
  // The masker reports the same when constructed with such a model.
  MaskingOptions m;
  m.segmenter.model_path = dir + "/flatten.onnx";
  Camera camera = Camera::FromFov(64, 48, 1.0);
  EXPECT_INVALID_INPUT(DynamicMasker(m, camera), "flatten.onnx");
}

}  // namespace
}  // namespace dypho
