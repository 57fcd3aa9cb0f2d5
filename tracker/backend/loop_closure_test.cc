// Loop-closure stages on synthetic data with known answers: 3D-3D RANSAC +
// Umeyama verification (a true loop with outliers is found exactly; a wrong
// candidate is rejected) and the SE(3) pose graph (a drifting loop is
// corrected by one loop edge).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "common/check.h"
#include "tracker/backend/loop_verification.h"
#include "tracker/backend/pose_graph.h"

namespace dypho {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

Rigid3d TrueLoopTransform() {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 1.0, -0.3).normalized())),
                 Eigen::Vector3d(0.3, -0.1, 0.25));
}

TEST(LoopVerification, FindsTheTransformWithOutliers) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::normal_distribution<double> noise(0.0, 0.005);
  const Rigid3d a_from_b = TrueLoopTransform();
  std::vector<Eigen::Vector3d> a, b;
  std::vector<char> truth;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d pb(u(rng), u(rng), u(rng) + 3.0);
    const bool outlier = i % 5 < 2;  // 40% wrong matches
    b.push_back(pb);
    a.push_back(outlier ? Eigen::Vector3d(u(rng), u(rng), u(rng) + 3.0)
                        : Eigen::Vector3d(a_from_b * pb + Eigen::Vector3d(noise(rng), noise(rng), noise(rng))));
    truth.push_back(!outlier);
  }
  const LoopVerification v = VerifyLoop3d(a, b, LoopVerificationOptions());
  ASSERT_TRUE(v.accepted) << v.reason;
  // Every true match is an inlier; a random wrong one lands within 5 cm of
  // its true position with probability ~1e-4, i.e. none here.
  EXPECT_EQ(v.num_inliers, 120);
  for (size_t i = 0; i < truth.size(); ++i) EXPECT_EQ(v.inliers[i], truth[i]) << i;
  // 5 mm noise on 120 points: the fit is within a few mm and mrad.
  EXPECT_LT((v.a_from_b.translation - a_from_b.translation).norm(), 0.003);
  EXPECT_LT(RotationAngle(v.a_from_b.rotation, a_from_b.rotation), 0.002);
  EXPECT_LT(v.rmse, 0.012);

  // Exact correspondences: exact answer.
  std::vector<Eigen::Vector3d> exact_a;
  for (const Eigen::Vector3d& p : b) exact_a.push_back(a_from_b * p);
  const LoopVerification e = VerifyLoop3d(exact_a, b, LoopVerificationOptions());
  EXPECT_EQ(e.num_inliers, 200);
  EXPECT_LT((e.a_from_b.translation - a_from_b.translation).norm(), 1e-9);
  EXPECT_LT(RotationAngle(e.a_from_b.rotation, a_from_b.rotation), 1e-9);
}

// A wrong candidate: its "matches" are another place's points (repeated
// texture gives descriptor matches, not geometry): rejected.
TEST(LoopVerification, RejectsAWrongCandidate) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 150; ++i) {
    b.emplace_back(u(rng), u(rng), u(rng) + 3.0);
    a.emplace_back(u(rng), u(rng), u(rng) + 3.0);
  }
  const LoopVerification v = VerifyLoop3d(a, b, LoopVerificationOptions());
  EXPECT_FALSE(v.accepted);
  EXPECT_LT(v.num_inliers, 10);
  EXPECT_NE(v.reason.find("too few inliers"), std::string::npos) << v.reason;
  // Repeated texture: a grid of tiles whose corners are matched to the
  // wrong tiles of the same row (a permutation): every matched point is a
  // real grid point, yet no rigid motion explains many matches.
  std::vector<Eigen::Vector3d> ga, gb;
  for (int x = 0; x < 10; ++x)
    for (int y = 0; y < 10; ++y) {
      gb.emplace_back(0.2 * x, 0.2 * y, 3.0);
      ga.emplace_back(0.2 * ((x * 7 + y * 3) % 10), 0.2 * y, 3.0);
    }
  EXPECT_FALSE(VerifyLoop3d(ga, gb, LoopVerificationOptions()).accepted);
  // Too few correspondences, and bad input.
  EXPECT_FALSE(VerifyLoop3d(std::vector<Eigen::Vector3d>(a.begin(), a.begin() + 10),
                            std::vector<Eigen::Vector3d>(b.begin(), b.begin() + 10), LoopVerificationOptions())
                   .accepted);
  EXPECT_THROW(VerifyLoop3d(a, std::vector<Eigen::Vector3d>(3), LoopVerificationOptions()), InvalidInput);
}

// A circle of n poses (radius 2 m, looking outwards); odometry edges are
// the true relative motions with a small bias, so the poses integrated from
// them drift; one loop edge (last -> first) is exact.
struct Loop {
  std::vector<Rigid3d> truth, drifted;
  std::vector<PoseGraphEdge> edges;
};

Loop MakeLoop(int n, double bias) {
  Loop loop;
  for (int i = 0; i < n; ++i) {
    const double angle = 2.0 * M_PI * i / n;
    loop.truth.emplace_back(Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY())),
                            Eigen::Vector3d(2.0 * std::sin(angle), 0.1 * std::sin(3 * angle), 2.0 * std::cos(angle)));
  }
  Vector6d drift;
  drift << bias, 0.5 * bias, -bias, 0.2 * bias, bias, 0.0;
  loop.drifted.push_back(loop.truth[0]);
  for (int i = 1; i < n; ++i) {
    const Rigid3d measured = Rigid3d::Exp(drift) * (loop.truth[i - 1].Inverse() * loop.truth[i]);
    loop.edges.push_back({i - 1, i, measured, 1.0});
    loop.drifted.push_back(loop.drifted.back() * measured);
  }
  loop.edges.push_back({n - 1, 0, loop.truth[n - 1].Inverse() * loop.truth[0], 1.0});
  return loop;
}

double Rmse(const std::vector<Rigid3d>& a, const std::vector<Rigid3d>& b) {
  double sum = 0.0;
  for (size_t i = 0; i < a.size(); ++i) sum += (a[i].translation - b[i].translation).squaredNorm();
  return std::sqrt(sum / a.size());
}

TEST(PoseGraph, ExactEdgesGiveTheTruePoses) {
  Loop loop = MakeLoop(40, 0.0);
  std::vector<Rigid3d> poses = loop.truth;
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 0.02);
  for (size_t i = 1; i < poses.size(); ++i) {
    Vector6d d;
    for (int k = 0; k < 6; ++k) d[k] = n(rng);
    poses[i] = poses[i] * Rigid3d::Exp(d);
  }
  std::vector<char> fixed(poses.size(), 0);
  fixed[0] = 1;
  ASSERT_GT(Rmse(poses, loop.truth), 0.01);
  OptimizePoseGraph(&poses, fixed, loop.edges, PoseGraphOptions());
  EXPECT_LT(Rmse(poses, loop.truth), 1e-6);
}

TEST(PoseGraph, LoopEdgeRemovesMostOfTheDrift) {
  Loop loop = MakeLoop(60, 0.002);
  std::vector<Rigid3d> poses = loop.drifted;
  const double before = Rmse(poses, loop.truth);
  ASSERT_GT(before, 0.05);  // several cm of drift
  std::vector<char> fixed(poses.size(), 0);
  fixed[0] = 1;
  const PoseGraphSummary s = OptimizePoseGraph(&poses, fixed, loop.edges, PoseGraphOptions());
  const double after = Rmse(poses, loop.truth);
  std::printf("pose graph, 60 poses: RMSE %.4f m -> %.4f m, %d iterations, %.2f ms\n", before, after, s.iterations,
              s.solve_ms);
  EXPECT_LT(after, before / 3.0);
  EXPECT_LT(s.final_cost, s.initial_cost);
  // Without the loop edge nothing changes (the odometry alone is consistent).
  std::vector<PoseGraphEdge> odometry(loop.edges.begin(), loop.edges.end() - 1);
  std::vector<Rigid3d> open = loop.drifted;
  OptimizePoseGraph(&open, fixed, odometry, PoseGraphOptions());
  EXPECT_NEAR(Rmse(open, loop.truth), before, 1e-6);
}

TEST(PoseGraph, BadInputNamesTheEdge) {
  std::vector<Rigid3d> poses(3);
  std::vector<char> fixed = {1, 0, 0};
  std::vector<PoseGraphEdge> edges = {{0, 1, Rigid3d(), 1.0}, {1, 5, Rigid3d(), 1.0}};
  try {
    OptimizePoseGraph(&poses, fixed, edges, PoseGraphOptions());
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("edge 1 joins 1 and 5"), std::string::npos) << e.what();
  }
  EXPECT_THROW(OptimizePoseGraph(&poses, {0, 0, 0}, {{0, 1, Rigid3d(), 1.0}}, PoseGraphOptions()), InvalidInput);
}

}  // namespace
}  // namespace dypho
