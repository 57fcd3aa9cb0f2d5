// Tests of the motion cues of the masking: the flow-motion mask (with given
// and estimated poses), carrying masks along the flow, the epipolar motion-consistency check, and the shore/water/sky
// segmentation, on synthetic data with known answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "common/check.h"
#include "engine/synth/synthetic_scene.h"
#include "masking/async_segmenter.h"
#include "masking/dynamic_masker.h"
#include "masking/epipolar_check.h"
#include "masking/flow_motion.h"
#include "masking/shore_segmentation.h"
#include "tests/synth_sequence.h"
#include "tests/test_data.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

using testing::Gray;
using testing::MaskIou;
using testing::SynthSequence;

constexpr double kDeg = M_PI / 180.0;

double Precision(const cv::Mat& predicted, const cv::Mat& truth) {
  const double p = cv::countNonZero(predicted);
  return p > 0 ? cv::countNonZero(predicted & truth) / p : 1.0;
}
double Recall(const cv::Mat& predicted, const cv::Mat& truth) {
  const double t = cv::countNonZero(truth);
  return t > 0 ? cv::countNonZero(predicted & truth) / t : 1.0;
}



// ---------------------------------------------------------------------------
// Flow-motion mask

TEST_F(SynthSequence, FlowMotionMaskFindsTheWalkersWithTheTruePose) {
  FlowMotionOptions o;
  o.estimate_pose = false;
  FlowMotion motion(o, Cam());
  double precision = 0.0, recall = 0.0;
  for (int i = 1; i < 6; ++i) {
    const BackwardFlow flow = motion.ComputeFlow(Gray(Rgb(i)), Gray(Rgb(i - 1)));
    EXPECT_EQ(flow.field.size(), cv::Size(320, 240));
    const FlowMotionResult r = motion.Detect(flow, Depth(i), CamFromPrev(i));
    ASSERT_TRUE(r.has_pose);
    EXPECT_FALSE(r.pose_estimated);
    precision += Precision(r.mask, Mask(i)) / 5;
    recall += Recall(r.mask, Mask(i)) / 5;
  }
  std::printf("flow mask with the true pose: precision %.3f recall %.3f\n", precision, recall);
  EXPECT_GT(precision, 0.6);
  EXPECT_GT(recall, 0.3);
}

TEST_F(SynthSequence, FlowMotionEstimatesThePoseFromTheFlow) {
  FlowMotion motion(FlowMotionOptions(), Cam());
  FlowMotionOptions fixed;
  fixed.estimate_pose = false;
  FlowMotion with_given(fixed, Cam());
  const Rigid3d error(Eigen::Quaterniond(Eigen::AngleAxisd(1.0 * kDeg, Eigen::Vector3d(0.3, 1, 0).normalized())),
                      Eigen::Vector3d(0.03, -0.01, 0.0));
  // Precision and recall against the truth: [0] true pose, [1] estimated from
  // a poor prediction (1 degree and 3 cm off), [2] estimated from nothing,
  // [3] the poor prediction used as it is.
  double precision[4] = {0, 0, 0, 0}, recall[4] = {0, 0, 0, 0};
  double max_rotation = 0.0, max_translation = 0.0, motion_size = 0.0;
  for (int i = 1; i < 6; ++i) {
    const BackwardFlow flow = motion.ComputeFlow(Gray(Rgb(i)), Gray(Rgb(i - 1)));
    const Rigid3d truth = CamFromPrev(i);
    motion_size = std::max(motion_size, truth.translation.norm());
    FlowMotionResult r[4] = {with_given.Detect(flow, Depth(i), truth), motion.Detect(flow, Depth(i), error * truth),
                             motion.Detect(flow, Depth(i), std::nullopt),
                             with_given.Detect(flow, Depth(i), error * truth)};
    for (int k = 0; k < 4; ++k) {
      ASSERT_TRUE(r[k].has_pose);
      precision[k] += Precision(r[k].mask, Mask(i)) / 5;
      recall[k] += Recall(r[k].mask, Mask(i)) / 5;
    }
    for (int k = 1; k <= 2; ++k) {
      EXPECT_TRUE(r[k].pose_estimated);
      EXPECT_GT(r[k].pose_inliers, 300);
      max_rotation = std::max(max_rotation, RotationAngle(r[k].cam_from_prev.rotation, truth.rotation));
      max_translation = std::max(max_translation, (r[k].cam_from_prev.translation - truth.translation).norm());
    }
  }
  std::printf(
      "flow mask precision / recall: true pose %.3f / %.3f, estimated from a poor prediction %.3f / %.3f, "
      "from nothing %.3f / %.3f, poor prediction as is %.3f / %.3f; pose errors up to %.3f deg, %.4f m "
      "(motion up to %.4f m)\n",
      precision[0], recall[0], precision[1], recall[1], precision[2], recall[2], precision[3], recall[3],
      max_rotation / kDeg, max_translation, motion_size);
  // Between consecutive frames (about 1 cm apart) the flow pins the rotation
  // down well but the translation only to about a centimetre (see flow_motion.h).
  EXPECT_LT(max_rotation, 0.15 * kDeg);
  EXPECT_LT(max_translation, 0.015);
  for (int k = 1; k <= 2; ++k) {
    EXPECT_GT(precision[k], precision[0] - 0.1) << k;
    EXPECT_GT(recall[k], recall[0] - 0.15) << k;
  }
  EXPECT_LT(precision[3], 0.5 * precision[0]);  // without the estimate most of the mask is static scene
}

// The synthetic room without walkers.
SyntheticScene StaticScene(int frames) {
  SynthOptions o;
  o.frames = frames;
  o.seed = 9;
  o.num_walkers = 0;
  return SyntheticScene(o);
}

TEST(MaskingFlowMotion, AStaticSceneHasNoMovingPixels) {
  const SyntheticScene scene = StaticScene(3);
  const SynthFrame a = scene.Render(0), b = scene.Render(1);
  FlowMotion motion(FlowMotionOptions(), scene.camera());
  const BackwardFlow flow = motion.ComputeFlow(Gray(CvView(b.rgb)), Gray(CvView(a.rgb)));
  const FlowMotionResult r = motion.Detect(flow, CvView(b.depth_noisy), b.world_from_cam.Inverse() * a.world_from_cam);
  EXPECT_LT(cv::countNonZero(r.mask), 0.005 * r.mask.total());
}

// A pose whose motion is 15 % too large (as rolling-shutter rows, the depth
// taken before the colour image or blur make it look in fast motion): the
// residual grows with the flow, and relative_threshold absorbs it.
TEST(MaskingFlowMotion, RelativeThresholdAbsorbsAnErrorThatGrowsWithTheMotion) {
  const SyntheticScene scene = StaticScene(9);
  const SynthFrame a = scene.Render(0), b = scene.Render(8);  // 8 frames apart: a flow of tens of pixels
  const Rigid3d truth = b.world_from_cam.Inverse() * a.world_from_cam;
  const Eigen::AngleAxisd aa(truth.rotation);
  Rigid3d wrong;
  wrong.rotation = Eigen::AngleAxisd(1.15 * aa.angle(), aa.axis()).toRotationMatrix();
  wrong.translation = 1.15 * truth.translation;
  auto fraction = [&](double relative, const Rigid3d& pose) {
    FlowMotionOptions fo;
    fo.estimate_pose = false;
    fo.relative_threshold = relative;
    FlowMotion motion(fo, scene.camera());
    const BackwardFlow flow = motion.ComputeFlow(Gray(CvView(b.rgb)), Gray(CvView(a.rgb)));
    const FlowMotionResult r = motion.Detect(flow, CvView(b.depth_noisy), pose);
    return cv::countNonZero(r.mask) / static_cast<double>(r.mask.total());
  };
  const double exact = fraction(0.0, truth), off = fraction(0.0, wrong), off_relative = fraction(0.2, wrong);
  std::printf("static scene, 8 frames apart: moving fraction %.4f (true pose), %.4f (15 %% too far), %.4f (relative 0.2)\n",
              exact, off, off_relative);
  EXPECT_GT(off, 0.05);
  EXPECT_LT(off_relative, 0.01);
}

TEST_F(SynthSequence, WarpingAMaskAlongTheFlowFollowsTheWalkers) {
  FlowMotion motion(FlowMotionOptions(), Cam());
  double carried = 0.0, stale = 0.0;
  cv::Mat mask = Mask(0).clone();
  for (int i = 1; i < 5; ++i) {
    const BackwardFlow flow = motion.ComputeFlow(Gray(Rgb(i)), Gray(Rgb(i - 1)));
    mask = WarpMaskByFlow(mask, flow);  // carried from frame 0 through every flow
    carried = MaskIou(mask, Mask(i));
    stale = MaskIou(Mask(0), Mask(i));
  }
  std::printf("mask of frame 0 at frame 4: carried IoU %.3f, stale IoU %.3f\n", carried, stale);
  EXPECT_GT(carried, 0.8);
  EXPECT_GT(carried, stale + 0.05);
}

// ---------------------------------------------------------------------------
// Epipolar motion-consistency check

struct EpipolarPair {
  cv::Mat prev_gray, gray;
  cv::Rect object_prev;  // where the moving object is in the previous image
  cv::Point2f motion;    // its image motion [px]
  Camera camera;
  cv::Matx33d true_f;  // x_cur^T F x_prev = 0 from the known poses
};

// The static synthetic room seen from two poses 2 cm apart (sideways, with a
// small rotation: consecutive frames of a hand-held camera), with a textured card pasted at the same place in both
// images except for a vertical shift: the card moves across the (roughly
// horizontal) epipolar lines.
EpipolarPair MakeEpipolarPair() {
  SynthOptions o;
  o.frames = 2;
  o.seed = 21;
  o.num_walkers = 0;
  o.depth_noise = false;
  const SyntheticScene scene(o);
  EpipolarPair p;
  p.camera = scene.camera();
  const Rigid3d world_from_cam0 = scene.trajectory().world_from_cam.front();
  const Rigid3d cam0_from_cam1(Eigen::Quaterniond(Eigen::AngleAxisd(0.8 * kDeg, Eigen::Vector3d::UnitY())),
                               Eigen::Vector3d(0.02, 0.003, 0.005));
  const cv::Mat rgb0 = CvView(scene.RenderStatic(world_from_cam0, p.camera).rgb).clone();
  const cv::Mat rgb1 = CvView(scene.RenderStatic(world_from_cam0 * cam0_from_cam1, p.camera).rgb).clone();
  {  // F = K^-T [t]x R K^-1 with x1 = R x0 + t.
    const Rigid3d cam1_from_cam0 = cam0_from_cam1.Inverse();
    const Eigen::Matrix3d r = cam1_from_cam0.rotation.toRotationMatrix();
    const Eigen::Vector3d t = cam1_from_cam0.translation;
    Eigen::Matrix3d tx;
    tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
    Eigen::Matrix3d k;
    k << p.camera.fx, 0, p.camera.cx, 0, p.camera.fy, p.camera.cy, 0, 0, 1;
    const Eigen::Matrix3d f = k.inverse().transpose() * tx * r * k.inverse();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) p.true_f(i, j) = f(i, j);
  }
  p.prev_gray = Gray(rgb0);
  p.gray = Gray(rgb1);
  // The card: 120 x 90 px of random 6 px blocks, slightly blurred.
  std::mt19937 rng(7);
  cv::Mat card(90, 120, CV_8UC1);
  for (int y = 0; y < card.rows; y += 6)
    for (int x = 0; x < card.cols; x += 6) card(cv::Rect(x, y, 6, 6)).setTo(static_cast<int>(rng() % 256));
  cv::GaussianBlur(card, card, cv::Size(3, 3), 0.8);
  p.object_prev = cv::Rect(260, 180, 120, 90);
  p.motion = cv::Point2f(0.0f, 9.0f);
  card.copyTo(p.prev_gray(p.object_prev));
  card.copyTo(p.gray(p.object_prev + cv::Point(0, 9)));
  return p;
}

// Every robust fit of F (EpipolarOptions::method) flags the moving card.
class MaskingEpipolarMethod : public ::testing::TestWithParam<const char*> {};

TEST_P(MaskingEpipolarMethod, FlagsTheMovingObjectsFeaturesAndKeepsTheStaticOnes) {
  const EpipolarPair p = MakeEpipolarPair();
  EpipolarOptions options;
  options.method = GetParam();
  EpipolarChecker checker(options, p.camera);
  const EpipolarResult r = checker.Check(p.prev_gray, p.gray);
  ASSERT_TRUE(r.has_fundamental);
  // Truth: features inside the card (3 px from its edge; at the edge a
  // corner can belong to either side).
  const cv::Rect inner(p.object_prev.x + 3, p.object_prev.y + 3, p.object_prev.width - 6, p.object_prev.height - 6);
  int tp = 0, fp = 0, fn = 0, tn = 0, valid = 0;
  for (size_t i = 0; i < r.prev_points.size(); ++i) {
    if (!r.valid[i]) continue;
    const cv::Point2f& q = r.prev_points[i];
    const bool on_edge = p.object_prev.contains(q) && !inner.contains(q);
    if (on_edge) continue;
    ++valid;
    const bool truth = inner.contains(q);
    if (truth && r.dynamic[i])
      ++tp;
    else if (!truth && r.dynamic[i])
      ++fp;
    else if (truth)
      ++fn;
    else
      ++tn;
  }
  // The pair is what it should be: with the true F the static matches lie on
  // their epipolar lines and the card's do not.
  double static_sum = 0.0, card_sum = 0.0;
  int static_n = 0, card_n = 0;
  for (size_t i = 0; i < r.prev_points.size(); ++i) {
    if (!r.valid[i] || (p.object_prev.contains(r.prev_points[i]) && !inner.contains(r.prev_points[i]))) continue;
    const double d = EpipolarDistance(p.true_f, r.prev_points[i], r.points[i]);
    if (inner.contains(r.prev_points[i]))
      card_sum += d, ++card_n;
    else
      static_sum += d, ++static_n;
  }
  EXPECT_LT(static_sum / static_n, 0.2);
  EXPECT_GT(card_sum / card_n, 5.0);
  const double precision = tp / std::max(1.0, static_cast<double>(tp + fp));
  const double recall = tp / std::max(1.0, static_cast<double>(tp + fn));
  const double static_kept = tn / std::max(1.0, static_cast<double>(tn + fp));
  std::printf("epipolar check: %d valid features, %d on the object; precision %.3f recall %.3f, static kept %.3f\n",
              valid, tp + fn, precision, recall, static_kept);
  EXPECT_GT(tp + fn, 12);
  EXPECT_GT(valid, 150);
  EXPECT_GT(precision, 0.9);
  EXPECT_GT(recall, 0.9);
  EXPECT_GT(static_kept, 0.97);
  // The flagged features lie about 9 px from their epipolar lines.
  for (size_t i = 0; i < r.prev_points.size(); ++i)
    if (r.valid[i] && inner.contains(r.prev_points[i])) EXPECT_GT(r.distance[i], 5.0f);
}

INSTANTIATE_TEST_SUITE_P(Methods, MaskingEpipolarMethod,
                         ::testing::Values("fast_ransac", "ransac", "usac_accurate", "usac_fast", "magsac"));

TEST(MaskingEpipolar, ChecksGivenPointsAndDiscardsBordersAndBadPatches) {
  const EpipolarPair p = MakeEpipolarPair();
  EpipolarChecker checker(EpipolarOptions(), p.camera);
  std::vector<cv::Point2f> points = checker.DetectFeatures(p.prev_gray);
  ASSERT_GT(points.size(), 100u);
  EXPECT_LE(points.size(), 500u);
  points.push_back({3.0f, 200.0f});  // at the border
  const EpipolarResult r = checker.Check(p.prev_gray, p.gray, points);
  ASSERT_EQ(r.prev_points.size(), points.size());
  EXPECT_EQ(r.valid.back(), 0);
  EXPECT_EQ(r.dynamic.back(), 0);
  // A patch much brighter in the second frame (a reflection, a light) is discarded.
  cv::Mat changed = p.gray.clone();
  const cv::Rect patch(100, 100, 60, 60);
  changed(patch) += cv::Scalar(90);
  const EpipolarResult c = checker.Check(p.prev_gray, changed, points);
  int in_patch_valid = 0;
  for (size_t i = 0; i < points.size(); ++i)
    if (cv::Rect(105, 105, 50, 50).contains(points[i]) && c.valid[i]) ++in_patch_valid;
  EXPECT_EQ(in_patch_valid, 0);
  // Epipolar distance of a point on and off a known line: F for a pure x translation is [t]x.
  const cv::Matx33d f(0, 0, 0, 0, 0, -1, 0, 1, 0);  // epipolar lines are the rows y = y1
  EXPECT_NEAR(EpipolarDistance(f, {10, 20}, {50, 20}), 0.0, 1e-12);
  EXPECT_NEAR(EpipolarDistance(f, {10, 20}, {50, 27}), 7.0, 1e-12);
}

// ---------------------------------------------------------------------------
// Shore / water / sky

struct ShoreImage {
  cv::Mat rgb;
  cv::Mat truth;  // 255 = water or sky
};

// 320x240: sky (light blue gradient, small white clouds) in rows [0, 80),
// a shore band (brown and green texture, a grey building) in [80, 140),
// water (dark blue with lighter ripple lines and white glints) below, and a
// red boat on the water.
ShoreImage MakeShoreImage() {
  ShoreImage s;
  s.rgb = cv::Mat(240, 320, CV_8UC3);
  s.truth = cv::Mat(240, 320, CV_8UC1, cv::Scalar(0));
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> noise(-12, 12);
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) {
      cv::Vec3i c;
      if (y < 80) {
        c = cv::Vec3i(120 + y / 2, 175 + y / 3, 235);
      } else if (y < 140) {
        const bool green = ((x / 23 + y / 17) % 3) == 0;
        c = green ? cv::Vec3i(70, 125, 45) : cv::Vec3i(125, 85, 45);
      } else {
        const bool ripple = (y % 9) < 2;
        c = ripple ? cv::Vec3i(70, 130, 175) : cv::Vec3i(25, 80, 130);
      }
      for (int k = 0; k < 3; ++k) c[k] = std::clamp(c[k] + noise(rng), 0, 255);
      s.rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(c[0], c[1], c[2]);
      if (y < 80 || y >= 140) s.truth.at<uint8_t>(y, x) = 255;
    }
  }
  cv::rectangle(s.rgb, cv::Rect(200, 95, 50, 45), cv::Scalar(150, 150, 150), -1);  // building
  for (const cv::Point c : {cv::Point(40, 20), cv::Point(150, 35), cv::Point(270, 15)})
    cv::circle(s.rgb, c, 2, cv::Scalar(250, 250, 250), -1);  // small clouds
  for (const cv::Point c : {cv::Point(60, 170), cv::Point(180, 200), cv::Point(290, 225)})
    cv::circle(s.rgb, c, 1, cv::Scalar(255, 255, 255), -1);  // glints
  const cv::Rect boat(90, 180, 40, 14);
  cv::rectangle(s.rgb, boat, cv::Scalar(200, 30, 25), -1);
  s.truth(boat).setTo(0);
  return s;
}

TEST(MaskingShore, MasksWaterAndSkyButNotTheShore) {
  const ShoreImage s = MakeShoreImage();
  const ShoreSegmentation r = SegmentShore(s.rgb, ShoreOptions());
  ASSERT_EQ(r.water_sky.size(), s.rgb.size());
  const double iou = MaskIou(r.water_sky, s.truth);
  const double shore_masked = static_cast<double>(cv::countNonZero(r.water_sky(cv::Rect(0, 84, 320, 52)))) / (320 * 52);
  std::printf("shore segmentation: IoU %.3f, Otsu hue %.0f, shore band masked %.3f\n", iou, r.otsu_hue, shore_masked);
  EXPECT_GT(iou, 0.93);
  EXPECT_LT(shore_masked, 0.03);
  EXPECT_GT(r.otsu_hue, 20);
  EXPECT_LT(r.otsu_hue, 100);
  // The clouds and glints are masked with the sky and water around them.
  EXPECT_EQ(r.water_sky.at<uint8_t>(35, 150), 255);
  EXPECT_EQ(r.water_sky.at<uint8_t>(200, 180), 255);
  // Without the erode-dilate-erode clean-up the small specks stay unmasked.
  ShoreOptions raw;
  raw.erode_px = raw.dilate_px = raw.final_erode_px = 0;
  raw.scale = 1.0;
  EXPECT_EQ(SegmentShore(s.rgb, raw).water_sky.at<uint8_t>(35, 150), 0);
  // Through the masker: off by default, on with use_shore.
  MaskingOptions m;
  m.use_flow = m.use_epipolar = m.use_background = false;
  const Camera camera = Camera::FromFov(320, 240, 1.2);
  DynamicMasker off(m, camera);
  EXPECT_EQ(cv::countNonZero(off.Process({s.rgb}).mask), 0);
  m.use_shore = true;
  DynamicMasker on(m, camera);
  EXPECT_GT(MaskIou(on.Process({s.rgb}).mask, s.truth), 0.93);
}

// ---------------------------------------------------------------------------
// Bad input

TEST_F(SynthSequence, BadInputsGiveClearErrors) {
  FlowMotion motion(FlowMotionOptions(), Cam());
  const cv::Mat gray = Gray(Rgb(1));
  EXPECT_INVALID_INPUT(motion.ComputeFlow(cv::Mat(), gray), "gray is empty");
  EXPECT_INVALID_INPUT(motion.ComputeFlow(gray, cv::Mat(100, 100, CV_8UC1)),
                       "prev_gray is 100x100 but must be 640x480");
  EXPECT_INVALID_INPUT(motion.ComputeFlow(Rgb(1), gray), "gray must be CV_8UC1");
  const BackwardFlow flow = motion.ComputeFlow(gray, Gray(Rgb(0)));
  EXPECT_INVALID_INPUT(motion.Detect(flow, cv::Mat(480, 640, CV_16UC1), CamFromPrev(1)), "depth must be CV_32FC1");
  EXPECT_INVALID_INPUT(motion.Detect(BackwardFlow(), Depth(1), CamFromPrev(1)), "flow");
  EXPECT_INVALID_INPUT(WarpMaskByFlow(cv::Mat(10, 10, CV_8UC1), flow), "prev_mask is 10x10");
  FlowMotionOptions bad;
  bad.residual_threshold_px = -1;
  EXPECT_INVALID_INPUT(FlowMotion(bad, Cam()), "FlowMotionOptions.residual_threshold_px");
  EpipolarChecker checker(EpipolarOptions(), Cam());
  EXPECT_INVALID_INPUT(checker.Check(gray, cv::Mat()), "gray is empty");
  EXPECT_INVALID_INPUT(checker.Check(gray, gray, {}, cv::Mat(5, 5, CV_8UC1)), "exclude is 5x5");
  EXPECT_INVALID_INPUT(SegmentShore(gray, ShoreOptions()), "rgb must be CV_8UC3");
  EXPECT_INVALID_INPUT(SegmentShore(cv::Mat(), ShoreOptions()), "rgb is empty");
  SegmenterScheduleOptions schedule;
  schedule.max_carry_frames = 0;
  EXPECT_INVALID_INPUT(AsyncSegmenter(CreateSegmenter(SegmenterOptions()), schedule), "max_carry_frames");
  // The masker checks every image against the camera.
  MaskingOptions m;
  DynamicMasker masker(m, Cam());
  EXPECT_INVALID_INPUT(masker.Process({}), "rgb is empty");
  MaskerInput in;
  in.rgb = cv::Mat(240, 320, CV_8UC3);
  EXPECT_INVALID_INPUT(masker.Process(in), "rgb is 320x240 but must be 640x480");
  in.rgb = Rgb(0);
  in.depth = cv::Mat(480, 640, CV_8UC1);
  EXPECT_INVALID_INPUT(masker.Process(in), "depth must be CV_32FC1");
  in.depth = Depth(0);
  in.rendered_depth = cv::Mat(480, 641, CV_32FC1);
  EXPECT_INVALID_INPUT(masker.Process(in), "rendered_depth is 641x480");
}

}  // namespace
}  // namespace dypho
