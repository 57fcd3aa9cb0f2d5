#include "engine/api_finish.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <utility>

#include "common/logging.h"

namespace dypho {

FinishSummary RunFinalRefinement(const EngineOptions& options, const FinishHooks& hooks,
                                 const std::function<void(int done, int planned)>& progress,
                                 std::optional<std::chrono::steady_clock::time_point> deadline) {
  // In chunks, so that readers (step_gate) and the time budget get a look in.
  constexpr int kChunk = 10;
  // The earlier of the time budget and the caller's deadline.
  using Clock = std::chrono::steady_clock;
  std::optional<Clock::time_point> until = deadline;
  std::string why = "deadline";
  if (options.final_seconds > 0) {
    const Clock::time_point budget =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options.final_seconds));
    if (!until || budget < *until) {
      until = budget;
      std::ostringstream text;
      text << options.final_seconds << " s budget";
      why = text.str();
    }
  }
  const int planned = options.final_iterations;
  FinishSummary summary;
  if (options.carve_votes > 0) {
    hooks.step_gate();
    summary.carved = hooks.carve(options.carve_votes);
    if (summary.carved > 0) {
      DYPHO_LOG(Info) << "removed " << summary.carved << " Gaussians that other keyframes see through";
    }
  }
  summary.holdout_frames = hooks.holdout_frames;
  // The last held-back loss read: checks run while it is finite.
  double last = hooks.holdout_frames == 0 ? std::nan("") : hooks.holdout_loss();
  summary.holdout_loss_start = summary.holdout_loss_end = last;
  summary.final_stop = "steps";
  // Converged: finish_patience checks in a row that each fall short of the
  // best loss so far by less than finish_tolerance of it. Against the best
  // and not the previous check, and more than two checks: the held-back loss
  // of a stochastic refinement plateaus for a few hundred steps at times (a
  // head250 run stopped after 600 steps, others ran 1800-2300). Nor before
  // finish_min_steps_per_keyframe steps per keyframe: a walkers run's loss
  // stalled for three checks after 500 steps (25 keyframes).
  const long min_steps = static_cast<long>(options.finish_min_steps_per_keyframe) * hooks.keyframes;
  double best = last;
  int done = 0, small_gains = 0;
  while (done < planned) {
    if (until && Clock::now() >= *until) {
      DYPHO_LOG(Info) << "final refinement stopped after " << done << " of " << planned << " steps (" << why << ")";
      summary.final_stop = why == "deadline" ? "deadline" : "time budget";
      break;
    }
    const int n = std::min(kChunk, planned - done);
    hooks.step_gate();
    hooks.optimize_all(n);
    done += n;
    if (progress) progress(done, planned);
    if (std::isfinite(last) && done % options.finish_check_every < kChunk && done < planned) {
      const double now = hooks.holdout_loss();
      summary.holdout_loss_end = now;
      small_gains = best - now < options.finish_tolerance * best ? small_gains + 1 : 0;
      DYPHO_LOG(Debug) << "final refinement: held-back loss " << now << " after " << done << " steps";
      last = now;
      best = std::min(best, now);
      if (small_gains >= options.finish_patience && done >= min_steps) {
        DYPHO_LOG(Info) << "final refinement converged after " << done << " steps (held-back loss "
                        << summary.holdout_loss_start << " -> " << now << ")";
        summary.final_stop = "converged";
        break;
      }
    }
  }
  if (std::isfinite(last) && summary.final_stop != "converged") summary.holdout_loss_end = hooks.holdout_loss();
  summary.final_steps = done;
  return summary;
}

double HoldoutLoss(const Mapper& mapper, const std::vector<KeyframeInput>& holdout, bool follow_keyframes) {
  if (mapper.num_gaussians() == 0) return std::nan("");
  const std::optional<KeyframeFollow> follow =
      follow_keyframes ? std::optional<KeyframeFollow>(MapperKeyframeFollow(mapper)) : std::nullopt;
  double sum = 0;
  int n = 0;
  for (const KeyframeInput& held : holdout) {
    std::optional<KeyframeInput> moved;
    if (follow) {
      moved = held;
      moved->cam_from_world = follow->MoveCamFromWorld(held.timestamp, held.cam_from_world);
    }
    const double l = mapper.AlignFrame(moved ? *moved : held, 0).loss_before;
    if (std::isfinite(l)) {
      sum += l;
      ++n;
    }
  }
  return n ? sum / n : std::nan("");
}

}  // namespace dypho
