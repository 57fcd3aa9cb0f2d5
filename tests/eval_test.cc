// Evaluation: timestamp association, ATE and RPE against hand-computed cases
// (TUM benchmark definitions), image and mask metrics, plots and reports.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "common/check.h"
#include "common/files.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/associate.h"
#include "engine/eval/ate.h"
#include "engine/eval/image_metrics.h"
#include "engine/eval/plots.h"
#include "engine/eval/report.h"
#include "engine/eval/trajectory.h"
#include "engine/io/image_io.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using ::dypho::testing::SharedData;
constexpr double kPi = 3.14159265358979323846;

Rigid3d Pose(double x, double y, double z) {
  return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, y, z));
}

Rigid3d RotZ(double angle_rad, const Eigen::Vector3d& t = Eigen::Vector3d::Zero()) {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ())), t);
}

// The 8 corners of the cube [-1, 1]^3 (centred, isotropic), and their parity
// x*y*z (+1 or -1; sums to zero and is orthogonal to every coordinate).
std::vector<Eigen::Vector3d> CubeCorners() {
  std::vector<Eigen::Vector3d> corners;
  for (int i = 0; i < 8; ++i) corners.emplace_back(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
  return corners;
}
double Parity(const Eigen::Vector3d& c) { return c.x() * c.y() * c.z(); }

// A non-degenerate 3-D trajectory: a helix with a varying orientation.
Trajectory Helix(int n, double dt, double t0 = 1000.0) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    const double a = 0.3 * i;
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()));
    t.Add(t0 + i * dt, Rigid3d(q, Eigen::Vector3d(std::cos(a), std::sin(a), 0.05 * i)));
  }
  return t;
}

// Applies `world2_from_world` (and a scale on translations) to every pose.
Trajectory Transform(const Trajectory& in, const Rigid3d& world2_from_world, double scale = 1.0) {
  Trajectory out;
  for (size_t i = 0; i < in.size(); ++i) {
    Rigid3d p = world2_from_world * in.world_from_cam[i];
    p.translation *= scale;
    out.Add(in.timestamps[i], p);
  }
  return out;
}

void ExpectInvalid(const std::function<void()>& f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "expected InvalidInput mentioning '" << part << "'";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------
// Association

TEST(EvalAssociateTest, GreedyBySmallestDifference) {
  // Candidates (|a - b|): (0,0) 0.004, (0,1) 0.012, (1,0) 0.006, (1,1) 0.002.
  // Greedy: (1,1) first, then (0,0).
  auto m = AssociateTimestamps({0.0, 0.010}, {0.004, 0.012}, 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].first, 0u);
  EXPECT_EQ(m[0].second, 0u);
  EXPECT_EQ(m[1].first, 1u);
  EXPECT_EQ(m[1].second, 1u);
  // One second stamp wanted by two: the closer first stamp gets it, the
  // other stays unmatched (not re-assigned to a worse partner).
  m = AssociateTimestamps({0.0, 0.005}, {0.004}, 0.02);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].first, 1u);
  // Strictly below the bound (0.5 and 0.25 are exact in binary).
  EXPECT_TRUE(AssociateTimestamps({1.0}, {1.5}, 0.5).empty());
  EXPECT_EQ(AssociateTimestamps({1.0}, {1.25}, 0.5).size(), 1u);
  // The offset is added to the second list.
  EXPECT_EQ(AssociateTimestamps({2.0}, {1.0}, 0.02, 1.0).size(), 1u);
  ExpectInvalid([] { AssociateTimestamps({1.0, 0.5}, {1.0}, 0.02); }, "sorted");
}

TEST(EvalAssociateTest, FindClosestIndex) {
  const std::vector<double> v{0.0, 1.0, 2.0, 3.0, 4.0};
  EXPECT_EQ(FindClosestIndex(v, -5.0), 0u);
  EXPECT_EQ(FindClosestIndex(v, 2.2), 2u);
  EXPECT_EQ(FindClosestIndex(v, 2.7), 3u);
  EXPECT_EQ(FindClosestIndex(v, 9.0), 4u);
  EXPECT_EQ(FindClosestIndex(v, 3.0), 3u);
}

// ---------------------------------------------------------------------------
// ATE

TEST(AteTest, ErrorStatsHandComputed) {
  const ErrorStats s = ComputeErrorStats({3.0, 1.0, 4.0, 2.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(30.0 / 4.0));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));  // population std
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(ComputeErrorStats({5.0, 1.0, 3.0}).median, 3.0);
  EXPECT_EQ(ComputeErrorStats({}).count, 0u);
}

TEST(AteTest, KnownRigidOffsetGivesZero) {
  const Trajectory gt = Helix(60, 0.1);
  const Rigid3d offset(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
                       Eigen::Vector3d(4.0, -2.0, 0.5));
  const Trajectory est = Transform(gt, offset);
  const AteResult ate = ComputeAte(gt, est);
  EXPECT_EQ(ate.translation.count, 60u);
  EXPECT_NEAR(ate.translation.rmse, 0.0, 1e-9);
  EXPECT_NEAR(ate.translation.max, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(ate.scale, 1.0);
  // The alignment is the inverse of the offset.
  const Rigid3d expected = offset.Inverse();
  EXPECT_NEAR(ate.gt_from_est.rotation.angularDistance(expected.rotation), 0.0, 1e-9);
  EXPECT_NEAR((ate.gt_from_est.translation - expected.translation).norm(), 0.0, 1e-9);
  // Without alignment the error would be large: the test can fail.
  EXPECT_GT((est.world_from_cam[0].translation - gt.world_from_cam[0].translation).norm(), 1.0);
}

TEST(AteTest, KnownScaleNeedsSim3) {
  // Ground truth: the cube corners (centred). Estimate: half the size, then
  // moved rigidly. SE(3) alignment cannot undo the scale: the best rotation
  // is the identity and every error is |1 - 0.5| * |corner| = 0.5 * sqrt(3).
  Trajectory gt;
  const auto corners = CubeCorners();
  for (size_t i = 0; i < corners.size(); ++i) gt.Add(i, Rigid3d(Eigen::Quaterniond::Identity(), corners[i]));
  const Rigid3d offset = RotZ(0.4, Eigen::Vector3d(1, 2, 3));
  Trajectory est;
  for (size_t i = 0; i < corners.size(); ++i) {
    est.Add(i, offset * Rigid3d(Eigen::Quaterniond::Identity(), 0.5 * corners[i]));
  }
  const AteResult se3 = ComputeAte(gt, est);
  EXPECT_NEAR(se3.translation.rmse, 0.5 * std::sqrt(3.0), 1e-9);
  EXPECT_NEAR(se3.translation.mean, 0.5 * std::sqrt(3.0), 1e-9);
  EXPECT_NEAR(se3.translation.std, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(se3.scale, 1.0);

  AteOptions sim3;
  sim3.estimate_scale = true;
  const AteResult with_scale = ComputeAte(gt, est, sim3);
  EXPECT_NEAR(with_scale.translation.rmse, 0.0, 1e-9);
  EXPECT_NEAR(with_scale.scale, 2.0, 1e-9);
  // The aligned estimate lies on the ground truth.
  const Trajectory aligned = AlignTrajectory(est, with_scale);
  for (size_t i = 0; i < gt.size(); ++i) {
    EXPECT_NEAR((aligned.world_from_cam[i].translation - gt.world_from_cam[i].translation).norm(), 0.0, 1e-9);
  }
}

TEST(AteTest, HandComputedSmallCase) {
  // 16 ground-truth points: the cube corners c and 2c. The estimate moves
  // each along z by 0.1 * parity (inner cube) or 0.3 * parity (outer cube).
  // These displacements sum to zero and are orthogonal to the points
  // (sum c d^T = 0), so the optimal alignment is the identity and the
  // errors are exactly 8 x 0.1 and 8 x 0.3:
  //   RMSE = sqrt((8 * 0.01 + 8 * 0.09) / 16) = sqrt(0.05), mean 0.2,
  //   median 0.2, std 0.1, min 0.1, max 0.3.
  // A rigid motion of the estimate must not change anything.
  Trajectory gt, est;
  const auto corners = CubeCorners();
  const Rigid3d motion(Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.2, -1, 0.4).normalized())),
                       Eigen::Vector3d(-3, 0.5, 7));
  double t = 50.0;
  for (double size : {1.0, 2.0}) {
    const double shift = size == 1.0 ? 0.1 : 0.3;
    for (const auto& c : corners) {
      gt.Add(t, Rigid3d(Eigen::Quaterniond::Identity(), size * c));
      est.Add(t + 0.005, motion * Rigid3d(Eigen::Quaterniond::Identity(),
                                          size * c + Eigen::Vector3d(0, 0, shift * Parity(c))));
      t += 0.1;
    }
  }
  const AteResult ate = ComputeAte(gt, est);
  EXPECT_EQ(ate.translation.count, 16u);
  EXPECT_NEAR(ate.translation.rmse, std::sqrt(0.05), 1e-9);
  EXPECT_NEAR(ate.translation.mean, 0.2, 1e-9);
  EXPECT_NEAR(ate.translation.median, 0.2, 1e-9);
  EXPECT_NEAR(ate.translation.std, 0.1, 1e-9);
  EXPECT_NEAR(ate.translation.min, 0.1, 1e-9);
  EXPECT_NEAR(ate.translation.max, 0.3, 1e-9);
  EXPECT_NEAR(ate.errors[0], 0.1, 1e-9);
  EXPECT_NEAR(ate.errors[15], 0.3, 1e-9);
}

TEST(AteTest, DroppedFramesAndUnmatchedEstimates) {
  const Trajectory gt = Helix(100, 0.1);
  const Rigid3d offset = RotZ(-0.3, Eigen::Vector3d(0.2, 0.1, -1));
  Trajectory est;
  // Every third pose only (the tracker dropped frames), timestamps 7 ms late,
  // plus two poses far outside the ground-truth time range.
  for (size_t i = 0; i < gt.size(); i += 3) est.Add(gt.timestamps[i] + 0.007, offset * gt.world_from_cam[i]);
  est.Add(gt.timestamps.back() + 5.0, Pose(100, 100, 100));
  est.Add(gt.timestamps.back() + 6.0, Pose(-100, 0, 0));
  const AteResult ate = ComputeAte(gt, est);
  EXPECT_EQ(ate.translation.count, 34u);  // ceil(100 / 3)
  EXPECT_EQ(ate.unmatched_estimates, 2u);
  EXPECT_NEAR(ate.translation.rmse, 0.0, 1e-9);
  for (size_t k = 0; k < ate.gt_indices.size(); ++k) EXPECT_EQ(ate.gt_indices[k], 3 * k);

  // Timestamps 25 ms off: nothing within 0.02 s; a wider bound matches.
  Trajectory late;
  for (size_t i = 0; i < gt.size(); i += 3) late.Add(gt.timestamps[i] + 0.025, gt.world_from_cam[i]);
  ExpectInvalid([&] { ComputeAte(gt, late); }, "0 of 34");
  AteOptions wide;
  wide.max_time_difference = 0.03;
  EXPECT_EQ(ComputeAte(gt, late, wide).translation.count, 34u);
  // ... or the time offset.
  AteOptions shifted;
  shifted.time_offset = -0.025;
  EXPECT_EQ(ComputeAte(gt, late, shifted).translation.count, 34u);
}

TEST(AteTest, RejectsBadInput) {
  const Trajectory gt = Helix(10, 0.1);
  Trajectory unsorted = gt;
  std::swap(unsorted.timestamps[2], unsorted.timestamps[3]);
  ExpectInvalid([&] { ComputeAte(gt, unsorted); }, "does not increase");
  AteOptions options;
  options.max_time_difference = -1;
  ExpectInvalid([&] { ComputeAte(gt, gt, options); }, "max_time_difference");
  Trajectory nan = gt;
  nan.world_from_cam[4].translation.x() = std::numeric_limits<double>::quiet_NaN();
  ExpectInvalid([&] { ComputeAte(gt, nan); }, "pose 4");
  Trajectory still;
  for (size_t i = 0; i < gt.size(); ++i) still.Add(gt.timestamps[i], Pose(1, 2, 3));
  AteOptions sim3;
  sim3.estimate_scale = true;
  ExpectInvalid([&] { ComputeAte(gt, still, sim3); }, "coincide");
}

TEST(AteTest, RealGroundTruthAgainstItselfAtFrameTimes) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  // The frames' interpolated ground truth, moved rigidly, as an "estimate":
  // every frame matches a ground-truth sample within 0.02 s (100 Hz motion
  // capture), and the remaining error is the motion within <= 5 ms.
  const auto dataset = OpenDataset(SharedData("tum_fr1_rpy_head250"));
  Trajectory est;
  const Rigid3d offset = RotZ(2.0, Eigen::Vector3d(10, 0, 0));
  for (const FrameInfo& f : dataset->frames()) est.Add(f.timestamp, offset * *f.world_from_cam_gt);
  const AteResult ate = ComputeAte(dataset->ground_truth(), est);
  EXPECT_EQ(ate.translation.count, 250u);
  EXPECT_LT(ate.translation.rmse, 0.005);
  EXPECT_GT(ate.translation.rmse, 0.0);
  // RPE of the same estimate: small but not zero.
  const RpeResult rpe = ComputeRpe(dataset->ground_truth(), est);
  EXPECT_GT(rpe.translation.count, 150u);
  EXPECT_LT(rpe.translation.rmse, 0.01);
  EXPECT_LT(rpe.rotation.rmse, 1.0);
}

// ---------------------------------------------------------------------------
// RPE

// Poses at 0, 0.1, ..., 3.0 s.
Trajectory Line(double speed, double yaw_rate, int n = 31, double dt = 0.1) {
  Trajectory t;
  for (int i = 0; i < n; ++i) t.Add(i * dt, RotZ(yaw_rate * i * dt, Eigen::Vector3d(speed * i * dt, 0, 0)));
  return t;
}

TEST(RpeTest, IdenticalTrajectoriesAndPairCount) {
  const Trajectory gt = Line(1.0, 0.2);
  const RpeResult rpe = ComputeRpe(gt, gt);
  // Pairs (i, j) with t_j closest to t_i + 1 s; pairs ending at the last pose
  // are skipped (as evaluate_rpe.py does): i = 0 .. 19, so 20 pairs.
  EXPECT_EQ(rpe.translation.count, 20u);
  EXPECT_NEAR(rpe.translation.max, 0.0, 1e-12);
  EXPECT_NEAR(rpe.rotation.max, 0.0, 1e-6);
  EXPECT_NEAR(rpe.pairs[3].est_time_1 - rpe.pairs[3].est_time_0, 1.0, 1e-12);
}

TEST(RpeTest, TranslationDriftPerSecond) {
  // Ground truth 1 m/s, estimate 1.1 m/s along x: 0.1 m error per second.
  const RpeResult rpe = ComputeRpe(Line(1.0, 0.0), Line(1.1, 0.0));
  EXPECT_EQ(rpe.translation.count, 20u);
  EXPECT_NEAR(rpe.translation.rmse, 0.1, 1e-9);
  EXPECT_NEAR(rpe.translation.min, 0.1, 1e-9);
  EXPECT_NEAR(rpe.rotation.max, 0.0, 1e-6);
  // The scale option undoes a uniform scale of the estimate.
  RpeOptions options;
  options.scale = 1.0 / 1.1;
  EXPECT_NEAR(ComputeRpe(Line(1.0, 0.0), Line(1.1, 0.0), options).translation.max, 0.0, 1e-9);
}

TEST(RpeTest, RotationDriftPerSecond) {
  // Turning in place at 10 deg/s vs 12 deg/s: 2 degrees per second.
  const double deg = kPi / 180.0;
  const RpeResult rpe = ComputeRpe(Line(0.0, 10 * deg), Line(0.0, 12 * deg));
  EXPECT_NEAR(rpe.rotation.rmse, 2.0, 1e-6);
  EXPECT_NEAR(rpe.rotation.median, 2.0, 1e-6);
  EXPECT_NEAR(rpe.translation.max, 0.0, 1e-12);
}

TEST(RpeTest, UsesTheTumErrorComposition) {
  // The estimate turns 90 degrees about z while moving 1 m along its own x
  // each second (a = [Rz(90), (1,0,0)]); the ground truth only moves
  // (b = [I, (1,0,0)]). evaluate_rpe.py's error is
  //   (E_j^-1 E_i)^-1 (G_j^-1 G_i) = a b^-1 = [Rz(90), (1,0,0) - Rz(90)(1,0,0)]
  // with translation (1, -1, 0): sqrt(2) m, and 90 degrees.
  // (The other common convention, b^-1 a, would give 0 m.)
  const Rigid3d a = RotZ(kPi / 2, Eigen::Vector3d(1, 0, 0));
  const Rigid3d b = Pose(1, 0, 0);
  Trajectory gt, est;
  Rigid3d e, g;
  for (int i = 0; i < 5; ++i) {
    gt.Add(i, g);
    est.Add(i, e);
    g = g * b;
    e = e * a;
  }
  const RpeResult rpe = ComputeRpe(gt, est);
  EXPECT_EQ(rpe.translation.count, 3u);  // (0,1), (1,2), (2,3); (3,4) ends at the last pose
  EXPECT_NEAR(rpe.translation.rmse, std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(rpe.rotation.mean, 90.0, 1e-6);
}

TEST(RpeTest, PairsWithoutGroundTruthAreSkipped) {
  // Ground truth at 0 .. 2 s (10 Hz); estimate at 0.03 + 0.1 k up to 4.03 s.
  // A pose is usable when the closest ground-truth stamp is within twice the
  // median ground-truth interval (0.2 s): t_j <= 2.13, so i = 0 .. 11.
  Trajectory gt, est;
  for (int k = 0; k <= 20; ++k) gt.Add(0.1 * k, Pose(0.1 * k, 0, 0));
  for (int k = 0; k <= 40; ++k) est.Add(0.03 + 0.1 * k, Pose(0.1 * k, 0, 0));
  const RpeResult rpe = ComputeRpe(gt, est);
  EXPECT_EQ(rpe.translation.count, 12u);
  EXPECT_NEAR(rpe.pairs.back().est_time_0, 1.13, 1e-9);
  // Each pose is compared with the closest ground-truth sample, 0.03 s
  // earlier, except 2.13 s whose closest sample is 2.0 s: the last pair sees
  // 0.9 m of ground-truth motion against 1.0 m estimated.
  for (size_t k = 0; k + 1 < rpe.pairs.size(); ++k) EXPECT_NEAR(rpe.pairs[k].translation_error, 0.0, 1e-9);
  EXPECT_NEAR(rpe.pairs.back().gt_time_1, 2.0, 1e-12);
  EXPECT_NEAR(rpe.pairs.back().translation_error, 0.1, 1e-9);
}

TEST(RpeTest, RejectsTrajectoriesThatDoNotOverlap) {
  const Trajectory gt = Line(1.0, 0.0);
  Trajectory far;
  for (int i = 0; i < 31; ++i) far.Add(1000.0 + 0.1 * i, Pose(i, 0, 0));
  ExpectInvalid([&] { ComputeRpe(gt, far); }, "RPE");
  // Shorter than delta: no pair.
  ExpectInvalid([&] { ComputeRpe(Line(1.0, 0.0, 5), Line(1.0, 0.0, 5)); }, "pairs");
}

// ---------------------------------------------------------------------------
// Image metrics

ImageF Pattern(int w, int h, int channels, double (*f)(int, int, int)) {
  ImageF img(w, h, channels);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c) img.at(x, y, c) = static_cast<float>(f(x, y, c));
  return img;
}

double PatternA(int u, int v, int) { return ((u * 7 + v * 13) % 17) / 16.0; }
double PatternB(int u, int v, int c) { return 0.8 * PatternA(u, v, c) + 0.1 + 0.05 * ((u * v) % 3); }

TEST(ImageMetricsTest, PsnrKnownValues) {
  const ImageF a = Pattern(20, 10, 3, PatternA);
  EXPECT_TRUE(std::isinf(Psnr(a, a)));
  ImageF b = a;
  for (float& v : b.pixels()) v += 0.1f;  // MSE 0.01 -> 20 dB
  EXPECT_NEAR(Psnr(a, b), 20.0, 1e-4);
  // Masked: an offset of 0.5 only where the mask excludes it.
  ImageF c = a;
  ImageU8 mask(20, 10, 1, 255);
  for (int y = 0; y < 10; ++y) {
    for (int x = 0; x < 5; ++x) {
      mask.at(x, y) = 0;
      for (int ch = 0; ch < 3; ++ch) c.at(x, y, ch) += 0.5f;
    }
  }
  EXPECT_TRUE(std::isinf(Psnr(a, c, mask)));
  EXPECT_LT(Psnr(a, c), 20.0);
  ImageU8 inverse(20, 10, 1);
  for (size_t i = 0; i < mask.size(); ++i) inverse.data()[i] = mask.data()[i] ? 0 : 1;
  EXPECT_NEAR(Psnr(a, c, inverse), 10.0 * std::log10(1.0 / 0.25), 1e-4);  // 6.02 dB
  EXPECT_TRUE(std::isnan(Psnr(a, c, ImageU8(20, 10, 1, 0))));
  ExpectInvalid([&] { Psnr(a, Pattern(19, 10, 3, PatternA)); }, "19x10x3");
  ExpectInvalid([&] { Psnr(a, a, ImageU8(4, 4, 1)); }, "mask");
}

TEST(ImageMetricsTest, SsimKnownValues) {
  const ImageF a = Pattern(16, 13, 1, PatternA);
  const ImageF b = Pattern(16, 13, 1, PatternB);
  EXPECT_NEAR(Ssim(a, a), 1.0, 1e-12);
  // Reference: an independent direct evaluation of Wang et al.'s formula
  // (11x11 Gaussian, sigma 1.5, C1 = 1e-4, C2 = 9e-4, valid positions) on
  // these two patterns.
  EXPECT_NEAR(Ssim(a, b), 0.9648117463695388, 1e-6);
  EXPECT_NEAR(Ssim(b, a), Ssim(a, b), 1e-12);
  // Constant images 0.5 and 0.6: only the luminance term remains,
  // (2 * 0.5 * 0.6 + C1) / (0.25 + 0.36 + C1).
  const ImageF half(20, 20, 3, 0.5f), six(20, 20, 3, 0.6f);
  EXPECT_NEAR(Ssim(half, six), (0.6 + 1e-4) / (0.61 + 1e-4), 1e-6);
  // Too small for one window.
  EXPECT_TRUE(std::isnan(Ssim(Pattern(10, 20, 1, PatternA), Pattern(10, 20, 1, PatternA))));
}

TEST(ImageMetricsTest, MaskedSsimIgnoresExcludedPixels) {
  const ImageF a = Pattern(40, 30, 3, PatternA);
  ImageF b = a;
  ImageU8 mask(40, 30, 1, 255);
  for (int y = 10; y < 20; ++y) {
    for (int x = 15; x < 25; ++x) {
      mask.at(x, y) = 0;
      for (int c = 0; c < 3; ++c) b.at(x, y, c) = 1.0f - b.at(x, y, c);  // a "dynamic" object
    }
  }
  EXPECT_LT(Ssim(a, b), 0.95);
  EXPECT_NEAR(Ssim(a, b, mask), 1.0, 1e-9);
  // An all-ones mask is the standard SSIM.
  const ImageF c = Pattern(40, 30, 3, PatternB);
  EXPECT_NEAR(Ssim(a, c, ImageU8(40, 30, 1, 1)), Ssim(a, c), 1e-12);
}

TEST(ImageMetricsTest, DepthL1OnlyWhereBothValid) {
  ImageF a(4, 1, 1), b(4, 1, 1);
  a.at(0, 0) = 1.0f;
  b.at(0, 0) = 1.5f;  // |d| 0.5
  a.at(1, 0) = 2.0f;
  b.at(1, 0) = 1.75f;  // |d| 0.25
  a.at(2, 0) = 0.0f;
  b.at(2, 0) = 3.0f;  // a invalid
  a.at(3, 0) = 4.0f;
  b.at(3, 0) = std::numeric_limits<float>::quiet_NaN();  // b invalid
  DepthL1Result r = DepthL1(a, b);
  EXPECT_EQ(r.count, 2u);
  EXPECT_EQ(r.candidates, 4u);
  EXPECT_NEAR(r.l1, 0.375, 1e-9);
  ImageU8 mask(4, 1, 1, 0);
  mask.at(1, 0) = 255;
  r = DepthL1(a, b, mask);
  EXPECT_EQ(r.count, 1u);
  EXPECT_NEAR(r.l1, 0.25, 1e-9);
  mask.at(1, 0) = 0;
  EXPECT_TRUE(std::isnan(DepthL1(a, b, mask).l1));
}

TEST(MaskMetricsTest, IouPrecisionRecallHandMade) {
  // 4x2 masks:   predicted 1 1 0 0    truth 1 0 1 1
  //                        1 0 0 0          1 0 0 1
  // TP = 2 (0,0),(0,1); FP = 1 (1,0); FN = 3 (2,0),(3,0),(3,1); TN = 2.
  ImageU8 pred(4, 2, 1, 0), truth(4, 2, 1, 0);
  pred.at(0, 0) = pred.at(1, 0) = pred.at(0, 1) = 255;
  truth.at(0, 0) = truth.at(2, 0) = truth.at(3, 0) = truth.at(0, 1) = truth.at(3, 1) = 1;
  const MaskScores s = CompareMasks(pred, truth);
  EXPECT_EQ(s.true_positives, 2u);
  EXPECT_EQ(s.false_positives, 1u);
  EXPECT_EQ(s.false_negatives, 3u);
  EXPECT_EQ(s.true_negatives, 2u);
  EXPECT_DOUBLE_EQ(s.Iou(), 2.0 / 6.0);
  EXPECT_DOUBLE_EQ(s.Precision(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(s.Recall(), 2.0 / 5.0);
  // Restricted to the left half: TP 2, FP 1, FN 0.
  ImageU8 left(4, 2, 1, 0);
  left.at(0, 0) = left.at(1, 0) = left.at(0, 1) = left.at(1, 1) = 1;
  const MaskScores l = CompareMasks(pred, truth, left);
  EXPECT_DOUBLE_EQ(l.Recall(), 1.0);
  EXPECT_DOUBLE_EQ(l.Precision(), 2.0 / 3.0);
  // Both empty: perfect agreement.
  const MaskScores empty = CompareMasks(ImageU8(3, 3, 1, 0), ImageU8(3, 3, 1, 0));
  EXPECT_DOUBLE_EQ(empty.Iou(), 1.0);
  EXPECT_DOUBLE_EQ(empty.Precision(), 1.0);
  // Summed over frames.
  MaskScores total = s;
  total += l;
  EXPECT_EQ(total.true_positives, 4u);
  EXPECT_DOUBLE_EQ(total.Precision(), 4.0 / 6.0);
  ExpectInvalid([&] { CompareMasks(pred, ImageU8(4, 3, 1)); }, "4x3x1");
}

// ---------------------------------------------------------------------------
// Plots and reports

size_t ColouredPixels(const ImageU8& img) {
  size_t n = 0;
  for (int y = 0; y < img.height(); ++y) {
    for (int x = 0; x < img.width(); ++x) {
      const int r = img.at(x, y, 0), g = img.at(x, y, 1), b = img.at(x, y, 2);
      if (std::max({r, g, b}) - std::min({r, g, b}) > 60) ++n;
    }
  }
  return n;
}

TEST(EvalPlotsTest, TrajectoryTopViewAndErrorPlot) {
  const Trajectory gt = Helix(80, 0.1);
  Trajectory est = Transform(gt, RotZ(0.2, Eigen::Vector3d(1, 0, 0)));
  for (size_t i = 0; i < est.size(); ++i) est.world_from_cam[i].translation.x() += 0.02 * std::sin(0.5 * i);
  const AteResult ate = ComputeAte(gt, est);
  const RpeResult rpe = ComputeRpe(gt, est);
  PlotOptions options;
  options.width = 640;
  options.height = 480;
  const ImageU8 top = DrawTrajectoryTopView(gt, est, ate, options);
  EXPECT_EQ(top.width(), 640);
  EXPECT_EQ(top.height(), 480);
  EXPECT_EQ(top.channels(), 3);
  EXPECT_GT(ColouredPixels(top), 500u);  // the error-coloured estimate and colour bar
  const ImageU8 errors = DrawErrorOverTime(ate, &rpe, options);
  EXPECT_EQ(errors.width(), 640);
  EXPECT_GT(ColouredPixels(errors), 100u);

  const std::string path = ::dypho::testing::TestTempDir() + "/plots/top.png";
  WritePlot(path, top);
  const ImageU8 back = ReadRgb8(path);
  EXPECT_EQ(back.width(), 640);
  EXPECT_EQ(back.pixels(), top.pixels());  // PNG is lossless
  options.plane = "ab";
  ExpectInvalid([&] { DrawTrajectoryTopView(gt, est, ate, options); }, "plane");
}

TEST(EvalPlotsTest, FrameGrid) {
  std::vector<FramePair> pairs(3);
  for (auto& p : pairs) {
    p.rendered = ImageU8(64, 48, 3, 200);
    p.real = ImageU8(64, 48, 1, 50);
    p.caption = "frame";
  }
  FrameGridOptions options;
  options.cell_width = 128;
  options.pairs_per_row = 2;
  const ImageU8 grid = DrawFrameGrid(pairs, options);
  EXPECT_EQ(grid.channels(), 3);
  EXPECT_GE(grid.width(), 2 * (2 * 128));
  EXPECT_GE(grid.height(), 2 * 96);
  // The first rendered image (value 200) sits below the header.
  bool found_rendered = false, found_real = false;
  for (int y = 0; y < grid.height(); ++y) {
    for (int x = 0; x < grid.width(); ++x) {
      found_rendered |= grid.at(x, y, 0) == 200 && grid.at(x, y, 1) == 200;
      found_real |= grid.at(x, y, 0) == 50 && grid.at(x, y, 2) == 50;
    }
  }
  EXPECT_TRUE(found_rendered);
  EXPECT_TRUE(found_real);
  ExpectInvalid([] { DrawFrameGrid({}); }, "no frames");
}

TEST(EvalReportTest, MarkdownTablesAndEvaluationReport) {
  MarkdownReport report("Run");
  report.AddHeading("Numbers");
  report.AddTable({"a", "b"}, {{"1", "x|y"}});
  report.AddImage("pic.png", "a picture");
  EXPECT_NE(report.text().find("| a | b |\n| --- | --- |\n| 1 | x\\|y |"), std::string::npos)
      << report.text();
  EXPECT_NE(report.text().find("![a picture](<pic.png>)"), std::string::npos);
  ExpectInvalid([&] { report.AddTable({"a", "b"}, {{"1"}}); }, "row 0");

  const Trajectory gt = Helix(50, 0.1);
  const Trajectory est = Transform(gt, RotZ(0.5, Eigen::Vector3d(0, 1, 0)), 1.0);
  TrajectoryEvaluation evaluation = EvaluateTrajectory(gt, est, AteOptions(), RpeOptions());
  evaluation.ground_truth_path = "gt.txt";
  evaluation.estimate_path = "est.txt";
  ASSERT_TRUE(evaluation.rpe.has_value());
  const std::string text = FormatEvaluation(evaluation);
  EXPECT_NE(text.find("absolute_translational_error.rmse 0.000000 m"), std::string::npos) << text;
  EXPECT_NE(text.find("rotational_error.max"), std::string::npos);

  const std::string dir = ::dypho::testing::TestTempDir() + "/report";
  const std::string path = WriteEvaluationReport(dir, gt, est, evaluation);
  EXPECT_TRUE(fs::exists(dir + "/trajectory_top.png"));
  EXPECT_TRUE(fs::exists(dir + "/error_over_time.png"));
  const std::string md = ReadTextFile(path);
  EXPECT_NE(md.find("(<trajectory_top.png>)"), std::string::npos);
  EXPECT_NE(md.find("(<error_over_time.png>)"), std::string::npos);
  EXPECT_NE(md.find("| rmse | 0.0000 m |"), std::string::npos) << md;
  // No temporary files left behind.
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry.path().string().find(".tmp."), std::string::npos) << entry.path();
  }

  // A trajectory too short for 1 s pairs: ATE only, with the reason.
  const Trajectory short_gt = Helix(5, 0.1);
  const TrajectoryEvaluation short_eval = EvaluateTrajectory(short_gt, short_gt, AteOptions(), RpeOptions());
  EXPECT_FALSE(short_eval.rpe.has_value());
  EXPECT_FALSE(short_eval.rpe_skipped.empty());
}

}  // namespace
}  // namespace dypho
