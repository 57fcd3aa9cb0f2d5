// Motion-only bundle adjustment on synthetic 3D-2D(+depth) problems with a
// known pose: exact recovery, Jacobians against finite differences (through
// the Gauss-Newton step), Huber + chi-square outlier rejection, mask
// weights, rolling-shutter corrections, the Ceres solver agreeing with the
// Eigen LM, and bad input.
#include "tracker/pose_optimizer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "common/check.h"

namespace dypho {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

Camera TestCamera() { return Camera{520.0, 515.0, 318.0, 242.0, 640, 480}; }

Rigid3d TruePose() {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, -1.0, 0.2).normalized())),
                 Eigen::Vector3d(0.2, -0.1, 0.5));
}

// Observations of random points in front of `cam_from_world`; every third
// one without depth.
std::vector<PoseObservation> MakeObservations(const Camera& camera, const Rigid3d& cam_from_world, int n,
                                              double pixel_noise, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<PoseObservation> obs;
  const Rigid3d world_from_cam = cam_from_world.Inverse();
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 + 3.0 * (uni(rng) + 1.0) / 2.0;
    const Eigen::Vector3d in_cam(uni(rng) * 0.55 * z, uni(rng) * 0.45 * z, z);
    PoseObservation o;
    o.point_world = world_from_cam * in_cam;
    o.pixel = camera.Project(in_cam) + pixel_noise * Eigen::Vector2d(noise(rng), noise(rng));
    if (i % 3 != 0) o.depth = z;
    o.sigma = std::pow(1.2, i % 4);
    obs.push_back(o);
  }
  return obs;
}

Rigid3d Perturb(const Rigid3d& pose, double rotation, double translation) {
  Vector6d d;
  d << translation, -translation, 0.5 * translation, rotation, 0.7 * rotation, -0.5 * rotation;
  return Rigid3d::Exp(d) * pose;
}

double RotationError(const Rigid3d& a, const Rigid3d& b) { return RotationAngle(a.rotation, b.rotation); }
double CentreError(const Rigid3d& a, const Rigid3d& b) {
  return (a.Inverse().translation - b.Inverse().translation).norm();
}

class PoseOptimizerSolvers : public ::testing::TestWithParam<PoseSolver> {};

TEST_P(PoseOptimizerSolvers, RecoversTheExactPoseFromNoiselessData) {
  const Camera camera = TestCamera();
  const std::vector<PoseObservation> obs = MakeObservations(camera, TruePose(), 60, 0.0, 1);
  PoseOptimizerOptions options;
  options.solver = GetParam();
  const PoseOptimizerResult r = OptimizePose(camera, obs, Perturb(TruePose(), 0.05, 0.08), options);
  ASSERT_TRUE(r.usable);
  EXPECT_EQ(r.num_inliers, 60);
  EXPECT_LT(RotationError(r.cam_from_world, TruePose()), 1e-9);
  EXPECT_LT(CentreError(r.cam_from_world, TruePose()), 1e-9);
  EXPECT_LT(r.cost, 1e-12);
}

TEST_P(PoseOptimizerSolvers, RejectsGrossOutliersByChiSquare) {
  const Camera camera = TestCamera();
  std::vector<PoseObservation> obs = MakeObservations(camera, TruePose(), 200, 0.5, 2);
  std::vector<char> corrupted(obs.size(), 0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> shift(15.0, 60.0);
  for (size_t i = 0; i < obs.size(); i += 4) {  // 25% outliers
    obs[i].pixel += Eigen::Vector2d(shift(rng), -shift(rng));
    corrupted[i] = 1;
  }
  PoseOptimizerOptions options;
  options.solver = GetParam();
  const PoseOptimizerResult r = OptimizePose(camera, obs, Perturb(TruePose(), 0.03, 0.05), options);
  ASSERT_TRUE(r.usable);
  int wrong = 0;
  for (size_t i = 0; i < obs.size(); ++i) wrong += (r.inliers[i] != 0) == (corrupted[i] != 0);
  EXPECT_EQ(wrong, 0) << "every corrupted observation must be an outlier and the rest inliers (up to noise)";
  EXPECT_LT(RotationError(r.cam_from_world, TruePose()), 2e-3);
  EXPECT_LT(CentreError(r.cam_from_world, TruePose()), 5e-3);
}

INSTANTIATE_TEST_SUITE_P(Solvers, PoseOptimizerSolvers, ::testing::Values(PoseSolver::kEigenLm, PoseSolver::kCeres),
                         [](const ::testing::TestParamInfo<PoseSolver>& info) {
                           return info.param == PoseSolver::kEigenLm ? std::string("EigenLm") : std::string("Ceres");
                         });

TEST(PoseOptimizer, EigenLmAndCeresAgreeOnNoisyData) {
  const Camera camera = TestCamera();
  std::vector<PoseObservation> obs = MakeObservations(camera, TruePose(), 150, 1.0, 4);
  for (size_t i = 0; i < obs.size(); i += 10) obs[i].pixel.x() += 25.0;
  for (size_t i = 0; i < obs.size(); ++i) obs[i].weight = 0.25 + 0.75 * ((i * 37) % 11) / 10.0;
  PoseOptimizerOptions eigen_options, ceres_options;
  ceres_options.solver = PoseSolver::kCeres;
  const Rigid3d start = Perturb(TruePose(), 0.02, 0.04);
  const PoseOptimizerResult a = OptimizePose(camera, obs, start, eigen_options);
  const PoseOptimizerResult b = OptimizePose(camera, obs, start, ceres_options);
  ASSERT_TRUE(a.usable && b.usable);
  EXPECT_EQ(a.num_inliers, b.num_inliers);
  EXPECT_LT(RotationError(a.cam_from_world, b.cam_from_world), 1e-6);
  EXPECT_LT(CentreError(a.cam_from_world, b.cam_from_world), 1e-6);
  EXPECT_NEAR(a.cost, b.cost, 1e-6 * a.cost);
}

// Huber: a moderate outlier (inside the chi-square gate of the first round
// only because everything starts as an inlier) pulls a least-squares fit
// more than a Huber fit. With one round (no rejection) the Huber estimate is
// closer to the truth.
TEST(PoseOptimizer, HuberLimitsTheInfluenceOfOutliers) {
  const Camera camera = TestCamera();
  std::vector<PoseObservation> obs = MakeObservations(camera, TruePose(), 40, 0.0, 5);
  for (size_t i = 0; i < 6; ++i) obs[i].pixel += Eigen::Vector2d(40.0, 25.0);
  PoseOptimizerOptions huber, squares;
  huber.rounds = squares.rounds = 1;
  huber.iterations_per_round = squares.iterations_per_round = 50;
  squares.huber = false;
  const PoseOptimizerResult h = OptimizePose(camera, obs, TruePose(), huber);
  const PoseOptimizerResult s = OptimizePose(camera, obs, TruePose(), squares);
  EXPECT_LT(CentreError(h.cam_from_world, TruePose()), 0.5 * CentreError(s.cam_from_world, TruePose()));
  EXPECT_LT(RotationError(h.cam_from_world, TruePose()), 0.5 * RotationError(s.cam_from_world, TruePose()));
}

// Observations with weight 0 (surely dynamic) have no influence at all,
// however wrong they are; they are still classified.
TEST(PoseOptimizer, ZeroWeightObservationsDoNotMoveThePose) {
  const Camera camera = TestCamera();
  std::vector<PoseObservation> obs = MakeObservations(camera, TruePose(), 50, 0.0, 6);
  // A "walker": 30 observations of points that moved by 20 cm.
  std::vector<PoseObservation> moving = MakeObservations(camera, TruePose(), 30, 0.0, 7);
  for (PoseObservation& o : moving) {
    o.point_world += Eigen::Vector3d(0.2, 0.0, 0.05);
    o.weight = 0.0;
    obs.push_back(o);
  }
  PoseOptimizerOptions options;
  options.rounds = 1;  // no rejection: only the weight protects the pose
  const PoseOptimizerResult r = OptimizePose(camera, obs, Perturb(TruePose(), 0.02, 0.03), options);
  EXPECT_LT(CentreError(r.cam_from_world, TruePose()), 1e-8);
  EXPECT_LT(RotationError(r.cam_from_world, TruePose()), 1e-8);
  for (int i = 50; i < 80; ++i) EXPECT_FALSE(r.inliers[i]) << i;
}

// The depth residual constrains what reprojection alone leaves weak: with a
// narrow field of view and points at one depth, the distance along the
// optical axis. (The default disparity sigma of 1 px is weak on purpose, as
// ORB-SLAM's for RGB-D; a sigma of 0.05 px shows the effect clearly.)
TEST(PoseOptimizer, DepthResidualConstrainsTheDistance) {
  const Camera camera = TestCamera();
  std::vector<PoseObservation> obs;
  const Rigid3d truth = TruePose();
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int i = 0; i < 80; ++i) {
    const Eigen::Vector3d in_cam(uni(rng) * 0.1, uni(rng) * 0.1, 3.0 + 0.02 * uni(rng));
    PoseObservation o;
    o.point_world = truth.Inverse() * in_cam;
    o.pixel = camera.Project(in_cam) + 0.5 * Eigen::Vector2d(noise(rng), noise(rng));
    o.depth = in_cam.z();
    obs.push_back(o);
  }
  std::vector<PoseObservation> no_depth = obs;
  for (PoseObservation& o : no_depth) o.depth = 0.0;
  PoseOptimizerOptions options;
  options.disparity_sigma_scale = 0.05;
  const Rigid3d start = Perturb(truth, 0.0, 0.1);
  const PoseOptimizerResult with = OptimizePose(camera, obs, start, options);
  const PoseOptimizerResult without = OptimizePose(camera, no_depth, start, options);
  std::printf("camera centre error: %.4f m with depth, %.4f m without\n", CentreError(with.cam_from_world, truth),
              CentreError(without.cam_from_world, truth));
  EXPECT_LT(CentreError(with.cam_from_world, truth), 0.03);
  EXPECT_LT(CentreError(with.cam_from_world, truth), 0.25 * CentreError(without.cam_from_world, truth));
}

// Rolling shutter: observations generated with a per-row camera motion are
// fitted exactly when the same corrections are given.
TEST(PoseOptimizer, RollingShutterCorrectionsAreApplied) {
  const Camera camera = TestCamera();
  std::vector<PoseObservation> obs = MakeObservations(camera, TruePose(), 80, 0.0, 9);
  Vector6d twist;
  twist << 0.1, 0.0, 0.05, 1.2, -0.4, 0.3;  // [m/s, rad/s]
  for (PoseObservation& o : obs) {
    // Regenerate the pixel with the camera of this row (a few iterations
    // because the row depends on the pixel).
    Eigen::Vector2d pixel = o.pixel;
    for (int it = 0; it < 5; ++it) {
      o.row_cam_from_cam = Rigid3d::Exp(twist * 0.03 * (pixel.y() / 479.0 - 0.5));
      pixel = camera.Project(o.row_cam_from_cam * (TruePose() * o.point_world));
    }
    o.pixel = pixel;
    if (o.depth > 0.0) o.depth = (o.row_cam_from_cam * (TruePose() * o.point_world)).z();
  }
  const PoseOptimizerResult r = OptimizePose(camera, obs, Perturb(TruePose(), 0.02, 0.02), PoseOptimizerOptions());
  EXPECT_EQ(r.num_inliers, 80);
  EXPECT_LT(CentreError(r.cam_from_world, TruePose()), 1e-9);
  // Ignoring the corrections gives a worse fit.
  for (PoseObservation& o : obs) o.row_cam_from_cam = Rigid3d();
  const PoseOptimizerResult global = OptimizePose(camera, obs, TruePose(), PoseOptimizerOptions());
  EXPECT_GT(CentreError(global.cam_from_world, TruePose()), 1e-4);
}

// The analytic Jacobian: one Gauss-Newton step from a tiny perturbation
// lands on the optimum (a wrong Jacobian would need many LM iterations, and
// a single iteration would not get within 1e-9).
TEST(PoseOptimizer, OneIterationConvergesFromATinyPerturbation) {
  const Camera camera = TestCamera();
  const std::vector<PoseObservation> obs = MakeObservations(camera, TruePose(), 60, 0.0, 10);
  PoseOptimizerOptions options;
  options.rounds = 1;
  options.iterations_per_round = 2;
  const PoseOptimizerResult r = OptimizePose(camera, obs, Perturb(TruePose(), 1e-5, 1e-5), options);
  EXPECT_LT(CentreError(r.cam_from_world, TruePose()), 1e-11);
  EXPECT_LT(RotationError(r.cam_from_world, TruePose()), 1e-11);
}

TEST(PoseOptimizer, TooFewObservationsAndPointsBehindTheCamera) {
  const Camera camera = TestCamera();
  std::vector<PoseObservation> obs = MakeObservations(camera, TruePose(), 2, 0.0, 11);
  PoseOptimizerResult r = OptimizePose(camera, obs, TruePose(), PoseOptimizerOptions());
  EXPECT_FALSE(r.usable);
  EXPECT_EQ(r.num_inliers, 0);
  obs = MakeObservations(camera, TruePose(), 30, 0.0, 12);
  for (int i = 0; i < 5; ++i) obs[i].point_world = TruePose().Inverse() * Eigen::Vector3d(0.1, 0.1, -2.0);
  r = OptimizePose(camera, obs, TruePose(), PoseOptimizerOptions());
  EXPECT_TRUE(r.usable);
  for (int i = 0; i < 5; ++i) EXPECT_FALSE(r.inliers[i]);
  EXPECT_LT(CentreError(r.cam_from_world, TruePose()), 1e-9);
}

TEST(PoseOptimizer, BadInputThrowsNamingTheProblem) {
  const Camera camera = TestCamera();
  std::vector<PoseObservation> obs = MakeObservations(camera, TruePose(), 10, 0.0, 13);
  auto expect = [&](const std::vector<PoseObservation>& o, const PoseOptimizerOptions& opt, const Rigid3d& pose,
                    const std::string& part) {
    try {
      OptimizePose(camera, o, pose, opt);
      ADD_FAILURE() << "expected InvalidInput mentioning " << part;
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  std::vector<PoseObservation> bad = obs;
  bad[3].pixel.x() = std::nan("");
  expect(bad, PoseOptimizerOptions(), TruePose(), "observation 3");
  bad = obs;
  bad[4].sigma = 0.0;
  expect(bad, PoseOptimizerOptions(), TruePose(), "observation 4");
  bad = obs;
  bad[5].weight = 2.0;
  expect(bad, PoseOptimizerOptions(), TruePose(), "observation 5");
  PoseOptimizerOptions options;
  options.chi2_mono = -1.0;
  expect(obs, options, TruePose(), "chi2_mono");
  Rigid3d nan_pose = TruePose();
  nan_pose.translation.x() = std::nan("");
  expect(obs, PoseOptimizerOptions(), nan_pose, "initial pose");
  // NaN depth is "no depth", not an error.
  obs[2].depth = std::nan("");
  EXPECT_TRUE(OptimizePose(camera, obs, TruePose(), PoseOptimizerOptions()).usable);
}

}  // namespace
}  // namespace dypho
