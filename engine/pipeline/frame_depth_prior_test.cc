// The background prior from earlier frames (frame_depth_prior.h): exact on
// a wall seen from known poses; a person a mask missed in one frame does not
// enter the prior, a masked one is removed; the store keeps frames apart and
// bounded.
#include "engine/pipeline/frame_depth_prior.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "common/check.h"

namespace dypho {
namespace {

Camera Cam() { return Camera::FromFov(80, 60, 1.2); }

// cam_from_world of a camera at (x, 0, 0) looking along +z (a wall at z = 2
// is 2 m away at every pixel).
Rigid3d At(double x) {
  Rigid3d p;
  p.translation = Eigen::Vector3d(-x, 0.0, 0.0);
  return p;
}

cv::Mat Wall() { return cv::Mat(60, 80, CV_32FC1, cv::Scalar(2.0f)); }

TEST(FrameDepthPrior, WallFromKnownPosesIsExactAndAMissedPersonStaysOut) {
  FrameDepthPriorOptions o;
  o.fuse = 4;
  o.min_agree = 2;
  o.spacing = 0.02;
  FrameDepthPrior prior(Cam(), o);
  EXPECT_TRUE(prior.Prior(At(0.0)).empty());
  // Frame at x = 0.00: a person 1 m away the mask missed (columns 30..39).
  cv::Mat first = Wall();
  first.colRange(30, 40).setTo(1.0f);
  EXPECT_TRUE(prior.Offer(first, cv::Mat(), At(0.0)));
  // Frame at x = 0.03: the person is there again, but masked.
  cv::Mat second = Wall(), mask(60, 80, CV_8UC1, cv::Scalar(0));
  second.colRange(50, 60).setTo(1.0f);
  mask.colRange(50, 60).setTo(255);
  EXPECT_TRUE(prior.Offer(second, mask, At(0.03)));
  EXPECT_TRUE(prior.Offer(Wall(), cv::Mat(), At(0.06)));
  EXPECT_TRUE(prior.Offer(Wall(), cv::Mat(), At(0.09)));
  EXPECT_FALSE(prior.Offer(Wall(), cv::Mat(), At(0.095)));  // too near a kept one
  EXPECT_EQ(prior.size(), 4u);

  const cv::Mat p = prior.Prior(At(0.045));
  ASSERT_EQ(p.type(), CV_32FC1);
  ASSERT_EQ(p.size(), cv::Size(80, 60));
  int valid = 0, wrong = 0;
  for (int y = 0; y < p.rows; ++y)
    for (int x = 0; x < p.cols; ++x) {
      const float z = p.at<float>(y, x);
      if (z <= 0.0f) continue;
      ++valid;
      if (std::abs(z - 2.0f) > 1e-4f) ++wrong;
    }
  EXPECT_EQ(wrong, 0);  // the missed person (one frame only) is not in it
  EXPECT_GT(valid, 60 * 60);  // most of the view (the edges: seen by fewer frames)

  // min_agree 0: the nearest frame's depth alone; the missed person of the
  // frame at x = 0 shows up at its pose.
  o.min_agree = 0;
  FrameDepthPrior lone(Cam(), o);
  lone.Offer(first, cv::Mat(), At(0.0));
  EXPECT_NEAR(lone.Prior(At(0.0)).at<float>(30, 35), 1.0f, 1e-4f);
  lone.Clear();
  EXPECT_EQ(lone.size(), 0u);
}

TEST(FrameDepthPrior, TheStoreKeepsTheNearestFramesWhenFull) {
  FrameDepthPriorOptions o;
  o.max_frames = 3;
  o.fuse = 1;
  o.min_agree = 0;
  o.spacing = 0.01;
  FrameDepthPrior prior(Cam(), o);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(prior.Offer(Wall() * (1.0 + i), cv::Mat(), At(0.1 * i)));
  // Full: a frame at x = 0.25 replaces the farthest kept one (x = 0).
  EXPECT_TRUE(prior.Offer(Wall() * 4.0, cv::Mat(), At(0.25)));
  EXPECT_EQ(prior.size(), 3u);
  EXPECT_NEAR(prior.Prior(At(0.0)).at<float>(30, 40), 2.0f * 2.0f, 1e-3f);  // nearest now x = 0.1 (wall x 2)
  EXPECT_NEAR(prior.Prior(At(0.26)).at<float>(30, 40), 2.0f * 4.0f, 1e-3f);
  // The rotation counts: a frame turned 10 degrees is 0.25 * 0.1745 m away.
  Rigid3d turned = At(0.0);
  turned.rotation = Eigen::AngleAxisd(10.0 * M_PI / 180.0, Eigen::Vector3d::UnitY());
  EXPECT_NEAR(prior.Distance(At(0.0), turned), 0.25 * 10.0 * M_PI / 180.0, 1e-9);
}

TEST(FrameDepthPrior, BadOptionsAndInputsNameTheField) {
  FrameDepthPriorOptions o;
  o.fuse = 0;
  EXPECT_THROW(
      {
        try {
          FrameDepthPrior p(Cam(), o);
        } catch (const InvalidInput& e) {
          EXPECT_NE(std::string(e.what()).find("fuse"), std::string::npos) << e.what();
          throw;
        }
      },
      InvalidInput);
  o = FrameDepthPriorOptions();
  o.min_agree = o.fuse;
  EXPECT_THROW(FrameDepthPrior(Cam(), o), InvalidInput);
  FrameDepthPrior prior(Cam(), FrameDepthPriorOptions());
  EXPECT_THROW(prior.Offer(cv::Mat(60, 80, CV_8UC1, cv::Scalar(0)), cv::Mat(), At(0)), InvalidInput);
  EXPECT_THROW(prior.Offer(Wall(), cv::Mat(30, 40, CV_8UC1, cv::Scalar(0)), At(0)), InvalidInput);
}

}  // namespace
}  // namespace dypho
