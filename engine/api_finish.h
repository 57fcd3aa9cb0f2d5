// The final refinement of Engine::Finish (engine/api.h): steps over every
// keyframe in chunks until the held-back frames' loss stops improving, the
// steps planned are done, or the time budget or the caller's deadline is
// reached; optionally free-space carving first. Internal to the engine
// library: the engine gives it its map through hooks, so that it takes its
// own locks.
#pragma once

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "engine/api.h"
#include "engine/map/mapper.h"
#include "engine/map/trajectory_follow.h"

namespace dypho {

struct FinishSummary {
  int carved = 0;
  int final_steps = 0;
  std::string final_stop;
  int holdout_frames = 0;
  double holdout_loss_start = 0.0, holdout_loss_end = 0.0;
};

struct FinishHooks {
  std::function<void()> step_gate;                 // before each map lock (readers first)
  std::function<void(int steps)> optimize_all;     // takes the map lock itself
  std::function<double()> holdout_loss;            // mean over the held-back frames; NaN when none
  std::function<int(int votes)> carve;             // Gaussians removed
  int holdout_frames = 0;
  int keyframes = 0;  // in the map (finish_min_steps_per_keyframe)
};

// The mean mapping loss of the held-back frames at their poses (with
// `follow_keyframes`, moved as the refined keyframes moved; the run's
// trajectory follows them the same way); NaN for an empty map or no frame.
double HoldoutLoss(const Mapper& mapper, const std::vector<KeyframeInput>& holdout, bool follow_keyframes);

// Uses options.final_iterations, final_seconds, finish_check_every,
// finish_tolerance, finish_patience, finish_min_steps_per_keyframe and
// carve_votes.
FinishSummary RunFinalRefinement(const EngineOptions& options, const FinishHooks& hooks,
                                 const std::function<void(int done, int planned)>& progress,
                                 std::optional<std::chrono::steady_clock::time_point> deadline);

}  // namespace dypho
