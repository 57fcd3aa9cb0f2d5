// Tests of the YOLOX detector (masking/yolox_detector.h): decoding of
// synthetic output tensors with known answers for square and rectangular
// inputs, the rectangular input's size, the fall-back to a square input for
// a model fixed at export, and the real YOLOX-nano model on the TUM
// fr3/walking_xyz frames.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "common/check.h"
#include "engine/dataset/dataset.h"
#include "masking/dnn_model.h"
#include "masking/dynamic_masker.h"
#include "masking/segmenter.h"
#include "masking/yolox_detector.h"
#include "tests/onnx_bytes.h"
#include "tests/test_data.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

const char* kYoloxModel = "models/yolox_nano.onnx";
const char* kWalkingFrames = "tum_fr3_walking_xyz_3frames";

SegmenterOptions RealModel() {
  SegmenterOptions o;
  o.model_path = testing::SharedData(kYoloxModel);
  return o;
}

double Fraction(const cv::Mat& mask, const cv::Rect& region) {
  return static_cast<double>(cv::countNonZero(mask(region))) / region.area();
}

double BoxIou(const cv::Rect2f& a, const cv::Rect2f& b) {
  const double inter = (a & b).area();
  return inter / (a.area() + b.area() - inter);
}

// ---------------------------------------------------------------------------
// YOLOX decoding

// Row of anchor (gx, gy) of `stride` in a YOLOX output for a WxH input.
int YoloxRow(int stride, int gx, int gy, const cv::Size& input) {
  int row = 0;
  for (int s : {8, 16, 32}) {
    const int grid_w = input.width / s, grid_h = input.height / s;
    if (s == stride) return row + gy * grid_w + gx;
    row += grid_w * grid_h;
  }
  return -1;
}

// Sets anchor (gx, gy, stride) to a box of centre (cx, cy) and size (w, h) in input pixels.
void SetYoloxAnchor(cv::Mat& out, int stride, int gx, int gy, double cx, double cy, double w, double h,
                    float objectness, int class_id, float class_score, const cv::Size& input = {416, 416}) {
  float* p = out.ptr<float>(0) + static_cast<size_t>(YoloxRow(stride, gx, gy, input)) * 85;
  p[0] = static_cast<float>(cx / stride - gx);
  p[1] = static_cast<float>(cy / stride - gy);
  p[2] = static_cast<float>(std::log(w / stride));
  p[3] = static_cast<float>(std::log(h / stride));
  p[4] = objectness;
  p[5 + class_id] = class_score;
}

TEST(MaskingYolox, DecodesASyntheticOutputWithAKnownAnswer) {
  EXPECT_EQ(YoloxAnchorCount({416, 416}), 3549);
  const int sizes[3] = {1, 3549, 85};
  cv::Mat out(3, sizes, CV_32F, cv::Scalar(0));
  // A person (stride 16, cell (10, 5)): centre (168, 88), 64 x 128 input px, score 0.9 * 0.8.
  SetYoloxAnchor(out, 16, 10, 5, 168, 88, 64, 128, 0.9f, 0, 0.8f);
  // A weaker duplicate of it in the neighbouring cell: suppressed by NMS.
  SetYoloxAnchor(out, 16, 11, 5, 172, 90, 60, 124, 0.8f, 0, 0.7f);
  // A second person far away (stride 32, cell (3, 9)): centre (110, 300), 50 x 100.
  SetYoloxAnchor(out, 32, 3, 9, 110, 300, 50, 100, 0.7f, 0, 0.9f);
  // A car (class 2), and a person below the score threshold.
  SetYoloxAnchor(out, 8, 40, 20, 330, 165, 40, 30, 0.9f, 2, 0.9f);
  SetYoloxAnchor(out, 8, 5, 5, 44, 44, 20, 20, 0.5f, 0, 0.4f);

  const cv::Size image(640, 480);
  const Letterbox lb = Letterbox::Make(image, {416, 416}, false);  // scale 0.65, no offset
  std::vector<Detection> people = DecodeYoloxOutput(out, {416, 416}, lb, image, {0}, 0.3, 0.45);
  ASSERT_EQ(people.size(), 2u);
  EXPECT_NEAR(people[0].score, 0.72f, 1e-5);
  EXPECT_EQ(people[0].class_id, 0);
  // Input box [136, 200] x [24, 152] -> image / 0.65.
  EXPECT_NEAR(people[0].box.x, 136 / 0.65, 1e-3);
  EXPECT_NEAR(people[0].box.y, 24 / 0.65, 1e-3);
  EXPECT_NEAR(people[0].box.width, 64 / 0.65, 1e-3);
  EXPECT_NEAR(people[0].box.height, 128 / 0.65, 1e-3);
  EXPECT_NEAR(people[1].score, 0.63f, 1e-5);
  EXPECT_NEAR(people[1].box.x, 85 / 0.65, 1e-3);
  EXPECT_NEAR(people[1].box.y, 250 / 0.65, 1e-3);

  std::vector<Detection> with_cars = DecodeYoloxOutput(out, {416, 416}, lb, image, {0, 2}, 0.3, 0.45);
  ASSERT_EQ(with_cars.size(), 3u);
  EXPECT_EQ(with_cars[0].class_id, 2);  // highest score 0.81
  EXPECT_NEAR(with_cars[0].box.x + 0.5 * with_cars[0].box.width, 330 / 0.65, 1e-3);
  // Lowering the threshold lets the weak person through; NMS off keeps the duplicate.
  EXPECT_EQ(DecodeYoloxOutput(out, {416, 416}, lb, image, {0}, 0.15, 0.45).size(), 3u);
  EXPECT_EQ(DecodeYoloxOutput(out, {416, 416}, lb, image, {0}, 0.3, 1.0).size(), 3u);
}

TEST(MaskingYolox, RejectsAnOutputOfTheWrongShape) {
  const Letterbox lb = Letterbox::Make({640, 480}, {416, 416}, false);
  const int wrong_rows[3] = {1, 3548, 85};
  EXPECT_INVALID_INPUT(
      DecodeYoloxOutput(cv::Mat(3, wrong_rows, CV_32F, cv::Scalar(0)), {416, 416}, lb, {640, 480}, {0}, 0.3, 0.45),
      "1x3548x85");
  const int too_few_classes[3] = {1, 3549, 10};
  EXPECT_INVALID_INPUT(
      DecodeYoloxOutput(cv::Mat(3, too_few_classes, CV_32F, cv::Scalar(0)), {416, 416}, lb, {640, 480}, {8}, 0.3, 0.45),
      "class id 8");
}


TEST(MaskingYolox, RectangularInputHoldsTheImageAtTheSquareInputsScale) {
  EXPECT_EQ(YoloxRectInput({640, 480}, 416), cv::Size(416, 320));  // 640x480 -> 416x312, rounded up
  EXPECT_EQ(YoloxRectInput({480, 640}, 416), cv::Size(320, 416));
  EXPECT_EQ(YoloxRectInput({1241, 376}, 416), cv::Size(416, 128));  // KITTI: 126 -> 128
  EXPECT_EQ(YoloxRectInput({500, 500}, 416), cv::Size(416, 416));
  EXPECT_EQ(YoloxRectInput({4000, 10}, 416), cv::Size(416, 32));  // never below one stride-32 cell
  EXPECT_EQ(YoloxRectInput({640, 480}, 640), cv::Size(640, 480));
  EXPECT_EQ(YoloxAnchorCount({416, 320}), 52 * 40 + 26 * 20 + 13 * 10);
  EXPECT_INVALID_INPUT(YoloxRectInput({640, 480}, 400), "edge 400");
}

TEST(MaskingYolox, DecodesARectangularOutputWithAKnownAnswer) {
  const cv::Size input(416, 320);
  const int sizes[3] = {1, YoloxAnchorCount(input), 85};
  cv::Mat out(3, sizes, CV_32F, cv::Scalar(0));
  // A person in the last row of stride-32 cells (gy 9 of 10): centre (150, 290), 60 x 40 input px.
  SetYoloxAnchor(out, 32, 4, 9, 150, 290, 60, 40, 0.9f, 0, 0.9f, input);
  // A person in stride-8 cell (51, 39), the last one: centre (410, 314), 12 x 12.
  SetYoloxAnchor(out, 8, 51, 39, 410, 314, 12, 12, 0.8f, 0, 0.9f, input);
  const cv::Size image(640, 480);
  const Letterbox lb = Letterbox::Make(image, input, false);
  EXPECT_DOUBLE_EQ(lb.scale, 0.65);
  const std::vector<Detection> people = DecodeYoloxOutput(out, input, lb, image, {0}, 0.3, 0.45);
  ASSERT_EQ(people.size(), 2u);
  EXPECT_NEAR(people[0].box.x, 120 / 0.65, 1e-3);
  EXPECT_NEAR(people[0].box.y, 270 / 0.65, 1e-3);
  EXPECT_NEAR(people[0].box.height, 40 / 0.65, 1e-3);
  EXPECT_NEAR(people[1].box.x, 404 / 0.65, 1e-3);
  EXPECT_NEAR(people[1].box.y, 308 / 0.65, 1e-3);
  EXPECT_NEAR(people[1].box.y + people[1].box.height, 480.0, 1e-3);  // clipped to the image
  // The square decoder rejects it: the shape names the input it expects.
  EXPECT_INVALID_INPUT(DecodeYoloxOutput(out, {416, 416}, lb, image, {0}, 0.3, 0.45), "1x2730x85");
}

Detection Box(float x, float y, float w, float h, float score, int class_id = 0) {
  Detection d;
  d.box = cv::Rect2f(x, y, w, h);
  d.score = score;
  d.class_id = class_id;
  return d;
}

TEST(MaskingYolox, AWeakBoxAroundAConfidentOneIsDropped) {
  // Frame 0 of the walkers composite (seed 23): a person at 0.76 and a box
  // at 0.3 around them, the monitor and the desk.
  const Detection person = Box(58, 6, 177, 423, 0.76f), around = Box(59, 0, 439, 462, 0.3f);
  std::vector<Detection> d = {person, around};
  DropWeakEnclosingBoxes(0.5, 0.8, &d);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].box, person.box);
  // Kept: a box scoring more than half of the one it holds (a near person in
  // front of a far one), one of another class, one holding less than 80 % of
  // it, and everything with the rule off.
  for (const Detection& other : {Box(59, 0, 439, 462, 0.4f), Box(59, 0, 439, 462, 0.3f, 2), Box(100, 0, 400, 462, 0.3f)}) {
    d = {person, other};
    DropWeakEnclosingBoxes(0.5, 0.8, &d);
    EXPECT_EQ(d.size(), 2u) << other.box << " " << other.score;
  }
  d = {person, around};
  DropWeakEnclosingBoxes(0.0, 0.8, &d);
  EXPECT_EQ(d.size(), 2u);
  // The smaller box is never the one dropped, whatever the scores; order is kept.
  d = {around, Box(0, 0, 50, 50, 0.9f), person};
  d[0].score = 0.2f;
  DropWeakEnclosingBoxes(0.5, 0.8, &d);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].score, 0.9f);
  EXPECT_EQ(d[1].box, person.box);
}

// A YOLOX-shaped model fixed at export to a 416x416 input: the image is
// reshaped to 1x519168 (fails for any other input size), the first 3549 x 85
// values are kept and reshaped to 1x3549x85.
std::string FixedShapeModel() {
  using namespace testing;
  return OnnxModel({OnnxNode("Reshape", {"images", "flat_shape"}, {"flat"}, "flatten_fixed"),
                    OnnxNode("Slice", {"flat", "starts", "ends", "axes"}, {"kept"}, "keep"),
                    OnnxNode("Reshape", {"kept", "out_shape"}, {"output"}, "to_anchors")},
                   {OnnxInt64Tensor("flat_shape", {1, 3 * 416 * 416}), OnnxInt64Tensor("starts", {0}),
                    OnnxInt64Tensor("ends", {3549 * 85}), OnnxInt64Tensor("axes", {1}),
                    OnnxInt64Tensor("out_shape", {1, 3549, 85})},
                   {1, 3, 416, 416}, {1, 3549, 85});
}

// Two 640x480 frames through a rect_input segmenter whose model fails at
// 416x320: both run at the square input.
void ExpectSquareFromTheFirstFrameOn(YoloxSegmenter* seg) {
  const cv::Mat rgb(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
  for (const char* name : {"a", "b"}) {
    EXPECT_NO_THROW(seg->Segment({rgb, cv::Mat(), name}));
    EXPECT_EQ(seg->last_input(), cv::Size(416, 416)) << "frame " << name;
  }
}

// Its outputs are pixel values, not detections: only the input shape is checked.
TEST(MaskingYolox, AModelFixedToASquareInputFallsBackToIt) {
  const std::string path = testing::TestTempDir() + "/fixed_square.onnx";
  testing::WriteBytes(path, FixedShapeModel());
  SegmenterOptions o;
  o.model_path = path;
  YoloxSegmenter seg(o);
  const cv::Mat rgb(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
  // Square: runs as exported.
  o.rect_input = false;
  YoloxSegmenter square(o);
  EXPECT_NO_THROW(square.Segment({rgb, cv::Mat(), "a"}));
  EXPECT_EQ(square.last_input(), cv::Size(416, 416));
  // Rectangular: the 416x320 try fails, the square input is used from then on.
  ExpectSquareFromTheFirstFrameOn(&seg);
}

// A model that runs at any input of at least 320x320 but always gives the
// 416x416 input's 3549 anchors (the top-left 320x320 of the image, flattened,
// its first 3549 x 85 values): at 416x320 the decoding rejects the anchor count.
std::string SquareAnchorsModel() {
  using namespace testing;
  return OnnxModel({OnnxNode("Slice", {"images", "zeros", "corner", "hw_axes"}, {"corner_crop"}, "crop"),
                    OnnxNode("Reshape", {"corner_crop", "flat_shape"}, {"flat"}, "flatten"),
                    OnnxNode("Slice", {"flat", "starts", "ends", "axes"}, {"kept"}, "keep"),
                    OnnxNode("Reshape", {"kept", "out_shape"}, {"output"}, "to_anchors")},
                   {OnnxInt64Tensor("zeros", {0, 0}), OnnxInt64Tensor("corner", {320, 320}),
                    OnnxInt64Tensor("hw_axes", {2, 3}), OnnxInt64Tensor("flat_shape", {1, 3 * 320 * 320}),
                    OnnxInt64Tensor("starts", {0}), OnnxInt64Tensor("ends", {3549 * 85}),
                    OnnxInt64Tensor("axes", {1}), OnnxInt64Tensor("out_shape", {1, 3549, 85})},
                   {1, 3, 416, 416}, {1, 3549, 85});
}

TEST(MaskingYolox, AModelGivingTheSquaresAnchorsAtAnyInputFallsBackToTheSquare) {
  const std::string path = testing::TestTempDir() + "/square_anchors.onnx";
  testing::WriteBytes(path, SquareAnchorsModel());
  SegmenterOptions o;
  o.model_path = path;
  YoloxSegmenter seg(o);
  ExpectSquareFromTheFirstFrameOn(&seg);
}

TEST(MaskingRealFrames, RectangularInputFindsThePeopleTheSquareOneFinds) {
  DYPHO_REQUIRE_SHARED_DATA(kWalkingFrames);
  DYPHO_REQUIRE_SHARED_DATA(kYoloxModel);
  const std::unique_ptr<Dataset> dataset = OpenDataset(testing::SharedData(kWalkingFrames));
  const SegmenterOptions o = RealModel();
  YoloxSegmenter rect(o);
  SegmenterOptions square_options = o;
  square_options.rect_input = false;
  YoloxSegmenter square(square_options);
  size_t people = 0;
  for (size_t i = 0; i < dataset->size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const Frame frame = dataset->Load(i);
    const SegmenterInput in{CvView(frame.rgb), CvView(frame.depth), ""};
    const Segmentation a = rect.Segment(in), b = square.Segment(in);
    EXPECT_EQ(rect.last_input(), cv::Size(416, 320));
    EXPECT_EQ(square.last_input(), cv::Size(416, 416));
    ASSERT_EQ(a.detections.size(), b.detections.size());
    people += a.detections.size();
    for (const Detection& d : b.detections) {
      double best = 0.0;
      for (const Detection& e : a.detections)
        if (e.class_id == d.class_id) best = std::max(best, BoxIou(d.box, e.box));
      EXPECT_GT(best, 0.9) << "square box " << d.box;
    }
    const double inter = cv::countNonZero(a.mask & b.mask), uni = cv::countNonZero(a.mask | b.mask);
    if (uni > 0) EXPECT_GT(inter / uni, 0.9);
  }
  EXPECT_GE(people, 4u);  // two in each of the first two frames
}

// ---------------------------------------------------------------------------
// The real detector on real frames (TUM fr3/walking_xyz, two people).

struct WalkingFrame {
  int index;
  std::vector<cv::Rect> people;        // boxes that must be (almost) covered: torsos, legs, heads
  std::vector<cv::Rect> people_boxes;  // approximate full extents, for detection IoU
  std::vector<cv::Rect> scene;         // desk and wall regions that must stay (mostly) unmasked
};

// Regions checked by hand on the images (drawn and looked at).
std::vector<WalkingFrame> WalkingFrames() {
  return {
      // Frame 0: a man sitting at the desk on the left, a man standing on the right.
      {0,
       {cv::Rect(65, 205, 65, 150), cv::Rect(100, 130, 45, 60), cv::Rect(505, 100, 100, 220),
        cv::Rect(495, 360, 90, 110)},
       {cv::Rect(50, 120, 190, 350), cv::Rect(465, 5, 175, 470)},
       {cv::Rect(270, 260, 205, 60), cv::Rect(160, 125, 120, 60), cv::Rect(360, 130, 120, 50),
        cv::Rect(100, 85, 330, 35)}},
      // Frame 1: both people at the image sides (blacked out in RGB, no depth on them).
      {1,
       {cv::Rect(10, 150, 90, 250), cv::Rect(470, 120, 80, 200), cv::Rect(485, 330, 40, 110)},
       {cv::Rect(0, 20, 160, 460), cv::Rect(445, 50, 185, 425)},
       {cv::Rect(175, 285, 200, 35), cv::Rect(170, 140, 250, 50), cv::Rect(225, 200, 120, 75)}},
  };
}

TEST(MaskingRealFrames, YoloxFindsBothPeopleAndMasksThemButNotTheDeskOrWall) {
  DYPHO_REQUIRE_SHARED_DATA(kWalkingFrames);
  DYPHO_REQUIRE_SHARED_DATA(kYoloxModel);
  const std::unique_ptr<Dataset> dataset = OpenDataset(testing::SharedData(kWalkingFrames));
  ASSERT_GE(dataset->size(), 2u);
  MaskingOptions options;
  options.segmenter.model_path = testing::SharedData(kYoloxModel);
  DynamicMasker masker(options, dataset->camera());
  EXPECT_EQ(masker.segmenter_name(), "yolox");
  for (const WalkingFrame& f : WalkingFrames()) {
    SCOPED_TRACE("frame " + std::to_string(f.index));
    const Frame frame = dataset->Load(f.index);
    ASSERT_TRUE(frame.has_depth);
    masker.Reset();  // the frames are seconds apart: no flow between them
    MaskerInput input;
    input.rgb = CvView(frame.rgb);
    input.depth = CvView(frame.depth);
    const MaskResult r = masker.Process(input);
    // Both people detected: each hand-drawn extent matches one person box.
    int people = 0;
    for (const Detection& d : r.detections) people += d.class_id == 0;
    EXPECT_EQ(people, 2);
    for (const cv::Rect& extent : f.people_boxes) {
      double best = 0.0;
      for (const Detection& d : r.detections) best = std::max(best, BoxIou(d.box, cv::Rect2f(extent)));
      EXPECT_GT(best, 0.6) << "no detection matches " << extent;
    }
    for (const cv::Rect& region : f.people) EXPECT_GT(Fraction(r.mask, region), 0.95) << "person " << region;
    for (const cv::Rect& region : f.scene) EXPECT_LT(Fraction(r.mask, region), 0.1) << "scene " << region;
    // The soft weight is 0 on people and 1 far from them.
    EXPECT_EQ(r.static_weight.at<float>(f.people[0].y + 5, f.people[0].x + 5), 0.0f);
    EXPECT_EQ(r.static_weight.at<float>(f.scene[0].y + 5, f.scene[0].x + 50), 1.0f);
  }
}

TEST(MaskingRealFrames, DepthShapesThePersonMaskInsideTheBox) {
  DYPHO_REQUIRE_SHARED_DATA(kWalkingFrames);
  DYPHO_REQUIRE_SHARED_DATA(kYoloxModel);
  const std::unique_ptr<Dataset> dataset = OpenDataset(testing::SharedData(kWalkingFrames));
  const SegmenterOptions o = RealModel();
  const std::unique_ptr<Segmenter> seg = CreateSegmenter(o);
  const Frame frame = dataset->Load(0);
  const Segmentation s = seg->Segment({CvView(frame.rgb), CvView(frame.depth), ""});
  // The sitting man's box also holds the keyboard, the desk edge and the wall
  // behind him: the depth-made mask covers much less than the box.
  for (const Detection& d : s.detections) {
    ASSERT_FALSE(d.mask.empty());
    const double fill = static_cast<double>(cv::countNonZero(d.mask)) / d.mask_roi.area();
    EXPECT_GT(d.depth, 1.0f);
    EXPECT_LT(d.depth, 3.5f);
    EXPECT_LT(fill, 0.85) << "box " << d.box;
    EXPECT_GT(fill, 0.3) << "box " << d.box;
  }
  // Without depth the boxes are filled whole.
  const Segmentation no_depth = seg->Segment({CvView(frame.rgb), cv::Mat(), ""});
  ASSERT_EQ(no_depth.detections.size(), s.detections.size());
  EXPECT_GT(cv::countNonZero(no_depth.mask), cv::countNonZero(s.mask) * 1.2);
}

}  // namespace
}  // namespace dypho
