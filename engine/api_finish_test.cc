// The final refinement's stop rule (engine/api_finish.h), on scripted
// held-back losses: it stops after finish_patience checks in a row that
// each fall short of the best loss so far by less than finish_tolerance; a
// plateau shorter than that, or a rise followed by a new best, does not stop
// it, nor does one before finish_min_steps_per_keyframe steps per keyframe;
// without held-back frames it runs the planned steps.
#include "engine/api_finish.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/camera.h"
#include "common/check.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

struct Scripted {
  std::vector<double> losses;  // the first is read before any step, then one per check
  size_t next = 0;
  int steps = 0;
  int carved_votes = -1;
};

FinishHooks Hooks(Scripted* s) {
  FinishHooks h;
  h.step_gate = [] {};
  h.optimize_all = [s](int n) { s->steps += n; };
  h.holdout_loss = [s] {
    const double l = s->next < s->losses.size() ? s->losses[s->next] : s->losses.back();
    ++s->next;
    return l;
  };
  h.carve = [s](int votes) {
    s->carved_votes = votes;
    return 0;
  };
  h.holdout_frames = s->losses.empty() ? 0 : 4;
  h.keyframes = 5;
  return h;
}

EngineOptions Options(int patience) {
  EngineOptions o;
  o.final_iterations = 3000;
  o.finish_check_every = 100;
  o.finish_tolerance = 0.002;
  o.finish_patience = patience;
  o.finish_min_steps_per_keyframe = 40;  // 200 steps for the 5 keyframes of Hooks
  return o;
}

TEST(FinalRefinementStop, APlateauOfTwoChecksDoesNotStopItWithPatienceThree) {
  // Steady gains, a two-check plateau at 600-700 steps, gains again, then a
  // long plateau from 1200 steps on.
  Scripted s;
  s.losses = {1.0, 0.9, 0.85, 0.82, 0.80, 0.79, 0.7899, 0.7898, 0.75, 0.72, 0.70, 0.69, 0.6899, 0.6898, 0.6897};
  const FinishSummary r = RunFinalRefinement(Options(3), Hooks(&s), nullptr, std::nullopt);
  EXPECT_EQ(r.final_stop, "converged");
  // Checks at 100, 200, ...: the plateau after 1100 steps (0.69) is 1200,
  // 1300, 1400.
  EXPECT_EQ(r.final_steps, 1400);
  EXPECT_EQ(s.steps, 1400);
  EXPECT_DOUBLE_EQ(r.holdout_loss_start, 1.0);
  EXPECT_DOUBLE_EQ(r.holdout_loss_end, 0.6897);
  EXPECT_EQ(s.carved_votes, 2);  // the default carving ran first

  // Two checks in a row (the rule before this one) stop at the first plateau.
  Scripted two;
  two.losses = s.losses;
  const FinishSummary r2 = RunFinalRefinement(Options(2), Hooks(&two), nullptr, std::nullopt);
  EXPECT_EQ(r2.final_stop, "converged");
  EXPECT_EQ(r2.final_steps, 700);
}

TEST(FinalRefinementStop, GainsAreCountedAgainstTheBestLossNotThePreviousCheck) {
  // The loss rises at 300 steps and falls back by more than the tolerance
  // of the previous check, but not below the best (0.80): no gain on the
  // best for three checks.
  Scripted s;
  s.losses = {1.0, 0.9, 0.80, 0.90, 0.85, 0.801, 0.70, 0.60};
  const FinishSummary r = RunFinalRefinement(Options(3), Hooks(&s), nullptr, std::nullopt);
  EXPECT_EQ(r.final_stop, "converged");
  EXPECT_EQ(r.final_steps, 500);
}

TEST(FinalRefinementStop, NotBeforeTheMinimumStepsPerKeyframe) {
  // A plateau from the first check on: three checks in a row after 300
  // steps; 20 keyframes x 40 steps hold it until 800.
  Scripted s;
  s.losses = {1.0, 0.9999, 0.9998, 0.9997, 0.9996, 0.9995, 0.9994, 0.9993, 0.9992, 0.9991};
  FinishHooks h = Hooks(&s);
  const FinishSummary early = RunFinalRefinement(Options(3), h, nullptr, std::nullopt);
  EXPECT_EQ(early.final_steps, 300);
  s.next = 0;
  s.steps = 0;
  h.keyframes = 20;
  const FinishSummary r = RunFinalRefinement(Options(3), h, nullptr, std::nullopt);
  EXPECT_EQ(r.final_stop, "converged");
  EXPECT_EQ(r.final_steps, 800);
  EXPECT_DOUBLE_EQ(r.holdout_loss_end, 0.9992);
}

TEST(FinalRefinementStop, RunsThePlannedStepsWhenTheLossKeepsFallingOrNoFrameIsHeldBack) {
  Scripted falling;
  for (int i = 0; i <= 40; ++i) falling.losses.push_back(std::pow(0.99, i));
  EngineOptions o = Options(3);
  o.final_iterations = 2000;
  const FinishSummary r = RunFinalRefinement(o, Hooks(&falling), nullptr, std::nullopt);
  EXPECT_EQ(r.final_stop, "steps");
  EXPECT_EQ(r.final_steps, 2000);

  Scripted none;  // no held-back frame: the loss is never read
  const FinishSummary n = RunFinalRefinement(o, Hooks(&none), nullptr, std::nullopt);
  EXPECT_EQ(n.final_stop, "steps");
  EXPECT_EQ(n.final_steps, 2000);
  EXPECT_EQ(none.next, 0u);
}

TEST(FinalRefinementStop, PatienceBelowOneOrNegativeMinimumStepsIsAnInputError) {
  EngineOptions o = Options(3);
  o.camera = Camera{200, 200, 79.5, 59.5, 160, 120};
  EXPECT_NO_THROW(o.Validate());
  o.finish_patience = 0;
  EXPECT_INVALID_INPUT(o.Validate(), "EngineOptions.finish_patience must be >= 1");
  o.finish_patience = 3;
  o.finish_min_steps_per_keyframe = -1;
  EXPECT_INVALID_INPUT(o.Validate(), "EngineOptions.finish_min_steps_per_keyframe must be >= 0");
}

}  // namespace
}  // namespace dypho
