// Local bundle adjustment, covisibility and keyframe culling on synthetic
// sparse maps with exact observations (known answers).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "tracker/backend/covisibility.h"
#include "tracker/backend/keyframe_culling.h"
#include "tracker/backend/local_ba.h"
#include "tracker/backend/local_ba_test_maps.h"
#include "tracker/backend/local_ba_worker.h"

namespace dypho {
namespace {

using namespace ba_test;

// The BA tests run with each solver (LocalBaOptions::solver).
class LocalBa : public ::testing::TestWithParam<const char*> {
 protected:
  LocalBaOptions Options() const {
    LocalBaOptions options;
    options.solver = GetParam();
    return options;
  }
};

LocalBaSolution Solve(const SparseMap& map, int kf, const LocalBaOptions& options) {
  const Camera cam = TestCamera();
  return SolveLocalBa(cam, BuildLocalBaProblem(map, kf, options, cam, 1.2, 0.0), options, PoseOptimizerOptions());
}

TEST_P(LocalBa, RecoversPosesAndPointsFromExactObservations) {
  const SparseMap truth = MakeMap(6, 400, 0.15, 1);
  SparseMap map = truth;
  Perturb(&map, 2, /*first_keyframe=*/1);
  ASSERT_GT(MaxPoseError(map, truth), 0.02);
  ASSERT_GT(MaxPointError(map, truth), 0.02);
  LocalBaOptions options = Options();
  options.first_iterations = 10;
  options.iterations = 20;
  const LocalBaSolution solution = Solve(map, 5, options);
  ASSERT_TRUE(solution.usable);
  EXPECT_EQ(solution.problem.keyframes.size(), 6u);
  EXPECT_EQ(solution.problem.num_free_keyframes(), 5);  // keyframe 0 holds the gauge
  EXPECT_LT(solution.final_cost, 1e-3 * solution.initial_cost);
  const LocalBaApplied applied = ApplyLocalBa(solution, &map);
  EXPECT_EQ(applied.keyframes, 5);
  EXPECT_EQ(applied.points, static_cast<int>(solution.problem.points.size()));
  EXPECT_EQ(applied.erased, 0);
  EXPECT_LT(MaxPoseError(map, truth), 1e-4);
  EXPECT_LT(MaxPointError(map, truth), 1e-4);
}

TEST_P(LocalBa, ErasesGrossOutliersAndIgnoresZeroWeight) {
  const SparseMap truth = MakeMap(5, 300, 0.15, 3);
  SparseMap map = truth;
  Perturb(&map, 4, 1);
  // Keyframe 4: two features moved by 40 px (wrong matches), one with weight
  // 0 moved by 80 px (a dynamic feature): neither may pull the solution.
  Keyframe& k4 = map.keyframes[4];
  ASSERT_GT(k4.size(), 10u);
  k4.points[0].x += 40.0f;
  k4.points[1].y -= 40.0f;
  k4.points[2].x += 80.0f;
  k4.weights[2] = 0.0f;
  const long bad0 = k4.map_points[0], bad1 = k4.map_points[1];
  LocalBaOptions options = Options();
  options.first_iterations = 10;
  options.iterations = 20;
  const LocalBaSolution solution = Solve(map, 4, options);
  ASSERT_TRUE(solution.usable);
  const LocalBaApplied applied = ApplyLocalBa(solution, &map);
  EXPECT_EQ(applied.erased, 3);
  EXPECT_EQ(map.keyframes[4].map_points[0], -1);
  EXPECT_EQ(map.keyframes[4].map_points[1], -1);
  EXPECT_EQ(map.keyframes[4].map_points[2], -1);
  // The points keep their other observations and are not bad.
  EXPECT_FALSE(map.points[bad0].bad);
  EXPECT_FALSE(map.points[bad1].bad);
  EXPECT_LT(MaxPoseError(map, truth), 1e-4);
  EXPECT_LT(MaxPointError(map, truth), 1e-4);
}

TEST_P(LocalBa, WindowFollowsCovisibilityAndFixesTheRest) {
  // Keyframes 1 m apart: each sees only its neighbours' part of the cloud.
  const SparseMap truth = MakeMap(8, 800, 0.6, 5);
  SparseMap map = truth;
  Perturb(&map, 6, /*first_keyframe=*/5);  // the fixed keyframes keep their true poses
  const SparseMap before = map;
  LocalBaOptions options = Options();
  options.max_keyframes = 2;
  const LocalBaSolution solution = Solve(map, 7, options);
  ASSERT_TRUE(solution.usable);
  // The new keyframe and its 2 most covisible ones are free: 7, 6, 5.
  const auto covisible = CovisibleKeyframes(map, 7, options.min_shared);
  ASSERT_GE(covisible.size(), 2u);
  EXPECT_EQ(covisible[0].first, 6);
  EXPECT_EQ(covisible[1].first, 5);
  EXPECT_EQ(solution.problem.num_free_keyframes(), 3);
  for (size_t i = 0; i < solution.problem.keyframes.size(); ++i)
    EXPECT_EQ(solution.problem.fixed[i] == 0, solution.problem.keyframes[i] >= 5) << solution.problem.keyframes[i];
  ApplyLocalBa(solution, &map);
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(map.keyframes[k].cam_from_world.translation, before.keyframes[k].cam_from_world.translation) << k;
    EXPECT_EQ(map.keyframes[k].cam_from_world.rotation.coeffs(), before.keyframes[k].cam_from_world.rotation.coeffs());
  }
  // The free poses are found again (the fixed ones are true).
  for (int k = 5; k < 8; ++k) {
    const double err_before =
        (before.keyframes[k].cam_from_world * truth.keyframes[k].cam_from_world.Inverse()).translation.norm();
    const double err_after =
        (map.keyframes[k].cam_from_world * truth.keyframes[k].cam_from_world.Inverse()).translation.norm();
    EXPECT_GT(err_before, 5e-3) << k;
    EXPECT_LT(err_after, 1e-4) << k;
  }
}

TEST_P(LocalBa, WorkerGivesTheSynchronousSolution) {
  SparseMap map = MakeMap(5, 300, 0.15, 7);
  Perturb(&map, 8, 1);
  const Camera cam = TestCamera();
  const LocalBaOptions options = Options();
  const LocalBaProblem problem = BuildLocalBaProblem(map, 4, options, cam, 1.2, 0.0);
  const LocalBaSolution direct = SolveLocalBa(cam, problem, options, PoseOptimizerOptions());
  // On its thread, and synchronous (solved in Submit, kept until taken).
  for (const bool synchronous : {false, true}) {
    LocalBaWorker worker([&](LocalBaProblem p) { return SolveLocalBa(cam, std::move(p), options, PoseOptimizerOptions()); },
                         synchronous);
    EXPECT_FALSE(worker.Busy());
    ASSERT_TRUE(worker.Submit(problem));
    EXPECT_FALSE(worker.Submit(problem));  // one at a time
    if (synchronous) EXPECT_TRUE(worker.Busy());  // solved, not taken
    const std::optional<LocalBaSolution> solved = worker.WaitAndTake();
    ASSERT_TRUE(solved.has_value()) << synchronous;
    EXPECT_FALSE(worker.Busy());
    EXPECT_FALSE(worker.Take().has_value());
    ASSERT_EQ(solved->problem.positions.size(), direct.problem.positions.size());
    for (size_t j = 0; j < direct.problem.positions.size(); ++j)
      EXPECT_EQ(solved->problem.positions[j], direct.problem.positions[j]);
    EXPECT_EQ(solved->final_cost, direct.final_cost);
  }
}

INSTANTIATE_TEST_SUITE_P(Solvers, LocalBa, ::testing::Values("ceres", "eigen"));

TEST(KeyframeCulling, CullsOnlyRedundantKeyframes) {
  // Keyframes 0..5 0.05 m apart see nearly the same points (redundant).
  SparseMap map = MakeMap(6, 300, 0.05, 9);
  KeyframeCullingOptions options;
  std::vector<int> all = {0, 1, 2, 3, 4, 5};
  const int points_before = map.live_points;
  const std::vector<int> culled = CullRedundantKeyframes(all, options, &map);
  // Never the first or the 2 newest; the middle ones go while they are
  // redundant (each culling leaves fewer observers for the next).
  ASSERT_FALSE(culled.empty());
  for (int k : culled) {
    EXPECT_NE(k, 0);
    EXPECT_LT(k, 4);
    EXPECT_TRUE(map.keyframes[k].bad);
    EXPECT_TRUE(map.keyframes[k].descriptors.empty());  // features freed
  }
  EXPECT_EQ(map.live_keyframes, 6 - static_cast<int>(culled.size()));
  // No observation of a culled keyframe remains; no point lost its last one.
  for (const MapPoint& mp : map.points)
    for (int k : mp.keyframes) EXPECT_FALSE(map.keyframes[k].bad);
  EXPECT_EQ(map.live_points, points_before);
  // Every surviving keyframe is needed now: a second pass culls nothing
  // (each point of a survivor is seen by fewer than 3 others at >= 90%).
  const std::vector<int> again = CullRedundantKeyframes(all, options, &map);
  EXPECT_TRUE(again.empty());

  // Keyframes far apart are not redundant.
  SparseMap sparse = MakeMap(6, 600, 2.0, 10);
  EXPECT_TRUE(CullRedundantKeyframes(all, options, &sparse).empty());
}

TEST(SparseMap, EraseObservationMakesOrphanPointsBad) {
  SparseMap map = MakeMap(2, 50, 0.05, 11);
  long id = -1;
  int f0 = -1;
  for (size_t f = 0; f < map.keyframes[0].size() && id < 0; ++f) {
    const long candidate = map.keyframes[0].map_points[f];
    if (map.points[candidate].keyframes.size() == 2) {
      id = candidate;
      f0 = static_cast<int>(f);
    }
  }
  ASSERT_GE(id, 0);
  ASSERT_EQ(map.points[id].keyframes.size(), 2u);
  map.EraseObservation(0, f0);
  EXPECT_FALSE(map.points[id].bad);
  EXPECT_EQ(map.points[id].keyframes, std::vector<int>{1});
  const int f1 = map.points[id].features[0];
  map.EraseObservation(1, f1);
  EXPECT_TRUE(map.points[id].bad);
  EXPECT_EQ(map.live_points, 49);
}

}  // namespace
}  // namespace dypho
