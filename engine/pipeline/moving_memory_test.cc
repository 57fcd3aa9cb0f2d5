// The moving memory (engine/pipeline/moving_memory.h) on synthetic frames
// with known answers: a mover's points seen at one pose land where the
// camera's motion puts them; a flow component beside the remembered mover
// is confirmed, one elsewhere is not, and neither once the memory has
// forgotten; the map mask of each mode.
#include "engine/pipeline/moving_memory.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "common/check.h"

namespace dypho {
namespace {

constexpr int kW = 64, kH = 48;

Camera Pinhole() { return Camera{50.0, 50.0, 32.0, 24.0, kW, kH}; }

cv::Mat Block(int x0, int y0, int x1, int y1) {
  cv::Mat m(kH, kW, CV_8UC1, cv::Scalar(0));
  m(cv::Rect(x0, y0, x1 - x0, y1 - y0)).setTo(255);
  return m;
}

Rigid3d MovedRight(double metres) {  // the camera moved +x: the scene moves -x in the image
  Rigid3d cam_from_world;
  cam_from_world.translation = Eigen::Vector3d(-metres, 0.0, 0.0);
  return cam_from_world;
}

MovingMemoryOptions SmallOptions() {
  MovingMemoryOptions o;
  o.frames = 3;
  o.stride_px = 2;
  o.radius_px = 2.0;
  o.min_overlap = 0.25;
  o.min_component_px = 4;
  return o;
}

TEST(MovingMemory, PointsLandWhereTheCameraMotionPutsThem) {
  MovingMemoryOptions o = SmallOptions();
  o.radius_px = 0.0;
  o.stride_px = 1;
  MovingMemory memory(o, Pinhole());
  const cv::Mat depth(kH, kW, CV_32FC1, cv::Scalar(2.0f));
  memory.Add(Block(20, 10, 28, 30), depth, Rigid3d());
  EXPECT_EQ(memory.points(), 8u * 20u);
  // 0.2 m at 2 m depth with f = 50: 5 px to the left.
  const cv::Mat covered = memory.Project(MovedRight(0.2));
  EXPECT_EQ(cv::countNonZero(covered != Block(15, 10, 23, 30)), 0);
}

TEST(MovingMemory, DistortedCameraRoundTrip) {
  Camera c = Pinhole();
  c.distortion = {0.2, -0.1, 0.001, 0.002, 0.0};
  MovingMemoryOptions o = SmallOptions();
  o.radius_px = 0.0;
  o.stride_px = 1;
  MovingMemory memory(o, c);
  const cv::Mat mask = Block(2, 2, 12, 10);  // near a corner, where the distortion is strongest
  memory.Add(mask, cv::Mat(kH, kW, CV_32FC1, cv::Scalar(1.5f)), Rigid3d());
  EXPECT_EQ(cv::countNonZero(memory.Project(Rigid3d()) != mask), 0);
}

TEST(MovingMemory, ConfirmsTheComponentBesideTheRememberedMover) {
  MovingMemory memory(SmallOptions(), Pinhole());
  const cv::Mat depth(kH, kW, CV_32FC1, cv::Scalar(2.0f));
  memory.Add(Block(20, 10, 28, 30), depth, Rigid3d());
  // The next frame, camera 0.2 m to the right: the mover is at x 15..22;
  // it stepped 4 px further left, where the flow alone sees it.
  const cv::Mat beside = Block(11, 10, 19, 30), elsewhere = Block(45, 5, 60, 20), tiny = Block(16, 31, 18, 32);
  const cv::Mat flow_only = beside | elsewhere | tiny;
  const cv::Mat confirmed = memory.Confirm(flow_only, MovedRight(0.2));
  EXPECT_EQ(cv::countNonZero(confirmed != beside), 0);
  // Forgotten after `frames` frames without movers.
  const cv::Mat none(kH, kW, CV_8UC1, cv::Scalar(0));
  for (int i = 0; i < 3; ++i) memory.Add(none, depth, MovedRight(0.2));
  EXPECT_EQ(memory.points(), 0u);
  EXPECT_EQ(cv::countNonZero(memory.Confirm(flow_only, MovedRight(0.2))), 0);
}

TEST(MovingMemory, PixelsWithoutDepthAreNotRemembered) {
  MovingMemory memory(SmallOptions(), Pinhole());
  cv::Mat depth(kH, kW, CV_32FC1, cv::Scalar(2.0f));
  depth(cv::Rect(0, 0, 24, kH)).setTo(0.0f);
  memory.Add(Block(20, 10, 28, 30), depth, Rigid3d());
  EXPECT_EQ(memory.points(), 2u * 10u);  // columns 24 and 26 of the stride-2 grid (x = 1, 3, ...: 25, 27)
}

TEST(MovingMemory, MapMaskModes) {
  MovingMemory memory(SmallOptions(), Pinhole());
  const cv::Mat depth(kH, kW, CV_32FC1, cv::Scalar(2.0f));
  const cv::Mat person = Block(20, 10, 28, 30);
  memory.Add(person, depth, Rigid3d());
  MaskResult m;
  m.semantic_mask = person.clone();
  const cv::Mat beside = Block(28, 10, 32, 30), elsewhere = Block(45, 5, 60, 20);
  m.flow_mask = beside | elsewhere;
  m.flow_computed = true;
  m.mask = m.semantic_mask | m.flow_mask;
  EXPECT_EQ(cv::countNonZero(MapMask(m, "all", nullptr, depth, Rigid3d()) != m.mask), 0);
  EXPECT_EQ(cv::countNonZero(MapMask(m, "none", nullptr, depth, Rigid3d()) != person), 0);
  EXPECT_EQ(cv::countNonZero(MapMask(m, "confirmed", &memory, depth, Rigid3d()) != (person | beside)), 0);
  // Without a memory nothing is confirmed.
  EXPECT_EQ(cv::countNonZero(MapMask(m, "confirmed", nullptr, depth, Rigid3d()) != person), 0);
  // Flow pixels the refinement cleared stay cleared; no flow computed: the final mask.
  m.mask = person.clone();
  EXPECT_EQ(cv::countNonZero(MapMask(m, "none", nullptr, depth, Rigid3d()) != person), 0);
  m.flow_computed = false;
  m.mask = m.semantic_mask | m.flow_mask;
  EXPECT_EQ(cv::countNonZero(MapMask(m, "none", nullptr, depth, Rigid3d()) != m.mask), 0);
  EXPECT_THROW(MapMask(m, "some", nullptr, depth, Rigid3d()), InvalidInput);
  // The caller's final mask is left as it was.
  const cv::Mat before = m.mask.clone();
  m.flow_computed = true;
  MapMask(m, "none", nullptr, depth, Rigid3d());
  MapMask(m, "confirmed", &memory, depth, Rigid3d());
  EXPECT_EQ(cv::countNonZero(m.mask != before), 0);
}

// What a frame adds to the memory: its movers without the flow-only pixels,
// or with remember_confirmed the map's mask (the confirmed components too).
TEST(MovingMemory, RememberConfirmedAddsTheConfirmedComponents) {
  const cv::Mat depth(kH, kW, CV_32FC1, cv::Scalar(2.0f));
  const cv::Mat person = Block(20, 10, 28, 30), beside = Block(28, 10, 32, 30);
  MaskResult m;
  m.semantic_mask = person.clone();
  m.flow_mask = beside.clone();
  m.flow_computed = true;
  m.mask = person | beside;
  for (const bool remember : {false, true}) {
    MovingMemoryOptions o = SmallOptions();
    o.remember_confirmed = remember;
    MovingMemory memory(o, Pinhole());
    memory.Add(person, depth, Rigid3d());
    ASSERT_EQ(memory.points(), 40u);  // x 21..27, y 11..29 on the stride-2 grid
    EXPECT_EQ(cv::countNonZero(MapMask(m, "confirmed", &memory, depth, Rigid3d()) != m.mask), 0);
    EXPECT_EQ(memory.points(), remember ? 100u : 80u) << "remember_confirmed " << remember;
  }
}

TEST(MovingMemory, FlowMaskAtHalfSize) {
  MaskResult m;
  m.mask = Block(20, 10, 40, 30);
  cv::Mat half(kH / 2, kW / 2, CV_8UC1, cv::Scalar(0));
  half(cv::Rect(10, 5, 5, 10)).setTo(255);  // x 20..29, y 10..29 at full size
  m.semantic_mask = cv::Mat(kH / 2, kW / 2, CV_8UC1, cv::Scalar(0));
  m.flow_mask = half;
  m.flow_computed = true;
  const cv::Mat flow_only = FlowOnlyPixels(m);
  ASSERT_EQ(flow_only.size(), m.mask.size());
  EXPECT_EQ(cv::countNonZero(flow_only(cv::Rect(21, 11, 8, 18))), 8 * 18);  // inside, away from the edge
  EXPECT_EQ(cv::countNonZero(flow_only(cv::Rect(31, 0, 33, kH))), 0);
}

TEST(MovingMemory, BadInput) {
  MovingMemoryOptions o = SmallOptions();
  o.frames = 0;
  EXPECT_THROW(MovingMemory(o, Pinhole()), InvalidInput);
  o = SmallOptions();
  o.min_overlap = 0.0;
  EXPECT_THROW(MovingMemory(o, Pinhole()), InvalidInput);
  MovingMemory memory(SmallOptions(), Pinhole());
  const cv::Mat depth(kH, kW, CV_32FC1, cv::Scalar(2.0f));
  EXPECT_THROW(memory.Add(cv::Mat(10, 10, CV_8UC1, cv::Scalar(0)), depth, Rigid3d()), InvalidInput);
  EXPECT_THROW(memory.Add(Block(1, 1, 3, 3), cv::Mat(kH, kW, CV_8UC1), Rigid3d()), InvalidInput);
  EXPECT_THROW(memory.Confirm(cv::Mat(kH, kW, CV_32FC1), Rigid3d()), InvalidInput);
}

}  // namespace
}  // namespace dypho
