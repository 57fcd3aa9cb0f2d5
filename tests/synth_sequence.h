// The synthetic dynamic sequence shared by the masking tests
// (masking_motion_test.cc, async_segmenter_test.cc): rendered frames with
// their exact masks, and small mask helpers.
#pragma once

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <vector>

#include "engine/synth/synthetic_scene.h"
#include "tracker/cv_view.h"

namespace dypho::testing {

inline double MaskIou(const cv::Mat& a, const cv::Mat& b) {
  const double inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni > 0 ? inter / uni : 1.0;
}

inline cv::Mat Gray(const cv::Mat& rgb) {
  cv::Mat g;
  cv::cvtColor(rgb, g, cv::COLOR_RGB2GRAY);
  return g;
}

// Rendered frames of one synthetic dynamic sequence (640x480, two walkers),
// shared by the tests of a file.
class SynthSequence : public ::testing::Test {
 protected:
  static constexpr int kFrames = 10;
  static void SetUpTestSuite() {
    SynthOptions o;
    o.frames = 24;
    o.seed = 5;
    o.num_walkers = 2;
    scene_ = new SyntheticScene(o);
    frames_ = new std::vector<SynthFrame>();
    for (int i = 0; i < kFrames; ++i) frames_->push_back(scene_->Render(i));
  }
  static void TearDownTestSuite() {
    delete frames_;
    delete scene_;
    frames_ = nullptr;
    scene_ = nullptr;
  }
  static const SynthFrame& F(int i) { return (*frames_)[i]; }
  static cv::Mat Rgb(int i) { return CvView(F(i).rgb); }
  static cv::Mat Depth(int i) { return CvView(F(i).depth_noisy); }
  static cv::Mat Mask(int i) { return CvView(F(i).mask); }
  static Rigid3d CamFromPrev(int i) { return F(i).world_from_cam.Inverse() * F(i - 1).world_from_cam; }
  static const Camera& Cam() { return scene_->camera(); }

  static inline SyntheticScene* scene_ = nullptr;
  static inline std::vector<SynthFrame>* frames_ = nullptr;
};

}  // namespace dypho::testing
