// Mapping the real TUM fr1/rpy frames (../shared/data/tum_fr1_rpy_head250)
// with their ground-truth poses: a subset of frames and iterations so the
// test stays short. Asserts PSNR floors on the trained keyframes and on
// held-out frames (never trained on), and that the loss falls.
#include <gtest/gtest.h>

#include <cmath>

#include "engine/dataset/dataset.h"
#include "engine/map/map_sequence.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

TEST(MapTum, Fr1RpyWithGroundTruthPoses) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  const auto dataset = OpenDataset(::dypho::testing::SharedData("tum_fr1_rpy_head250"));
  SequenceMappingOptions opt;
  opt.max_frames = 24;
  opt.iterations_per_keyframe = 25;
  opt.final_iterations = 60;
  opt.heldout_every = 2;
  opt.mapper.num_threads = 2;
  PoseSource poses;  // ground truth
  const SequenceMappingResult r = MapSequence(*dataset, poses, opt);
  const double train = r.MeanPsnr(false), heldout = r.MeanPsnr(true);
  std::printf("fr1/rpy 24 frames: %zu keyframes, %d Gaussians, PSNR %.2f dB (keyframes), %.2f dB (%zu held-out), "
              "SSIM %.3f / %.3f, depth L1 %.1f / %.1f cm, loss %.4f -> %.4f\n",
              r.keyframe_frames.size(), r.stats.num_gaussians, train, heldout, r.heldout_scores.size(),
              r.MeanSsim(false), r.MeanSsim(true), 100 * r.MeanDepthL1(false), 100 * r.MeanDepthL1(true),
              r.loss_before_final, r.loss_after_final);
  ASSERT_GE(r.keyframe_frames.size(), 5u);
  ASSERT_GE(r.heldout_scores.size(), 4u);
  EXPECT_TRUE(r.frames_without_pose.empty());
  EXPECT_GT(train, 24.0);  // measured 25.6 dB
  EXPECT_GT(heldout, 22.0);  // measured 23.9 dB
  EXPECT_LT(r.MeanDepthL1(true), 0.05);  // [m]
  EXPECT_LT(r.loss_after_final, 0.95 * r.loss_before_final);
}

TEST(MapTum, MissingGroundTruthIsAClearError) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr3_walking_xyz_3frames");
  const auto dataset = OpenDataset(::dypho::testing::SharedData("tum_fr3_walking_xyz_3frames"));
  SequenceMappingOptions opt;
  EXPECT_INVALID_INPUT(MapSequence(*dataset, PoseSource(), opt), "groundtruth");
}

}  // namespace
}  // namespace dypho
