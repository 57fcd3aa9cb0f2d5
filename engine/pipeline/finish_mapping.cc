#include "engine/pipeline/finish_mapping.h"

#include <algorithm>
#include <optional>
#include <string>
#include <thread>

#include "common/logging.h"
#include "common/progress.h"
#include "engine/eval/report.h"

namespace dypho {

void FinishMapping(Engine* engine, const PipelineOptions& options, bool show_progress,
                   std::chrono::steady_clock::time_point finish_start, PipelineResult* result) {
  using Clock = std::chrono::steady_clock;
  if (result->interrupted) {
    DYPHO_LOG(Info) << "stopped after " << result->frames << " frames: mapping the queued keyframes, then writing";
    engine->EndOfStream();
    engine->WaitUntilIdle();
  } else {
    // The last keyframe candidate and the keyframes held for the frames
    // after them (seen_through) join the queue.
    engine->EndOfStream();
    const int queued = engine->QueueStatus().queued_keyframes;
    if (show_progress && queued > 0) {
      Progress drain("mapping the queued keyframes", queued);
      for (;;) {
        const int left = engine->QueueStatus().queued_keyframes;
        drain.Advance(std::max(0L, static_cast<long>(queued - left) - drain.done()));
        if (left == 0) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
      }
      drain.Finish();
    }
    engine->WaitUntilIdle();
    std::optional<Progress> final_progress;
    if (show_progress) final_progress.emplace("final refinement", options.final_iterations);
    std::optional<Clock::time_point> deadline;
    if (options.finish_seconds > 0)
      deadline = finish_start + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(options.finish_seconds));
    if (final_progress && deadline) final_progress->SetDeadline(*deadline);
    const std::string budget = deadline ? "stops " + FormatFixed(options.finish_seconds, 0) + " s after the last frame"
                                        : std::string();
    result->final_iterations = engine->Finish(
        [&](int done, int) {
          if (final_progress) final_progress->Advance(done - final_progress->done(), budget);
        },
        deadline);
    if (final_progress) final_progress->Finish();
  }
  result->finish_seconds = std::chrono::duration<double>(Clock::now() - finish_start).count();
  const EngineStatus status = engine->Status();
  result->keyframes = status.keyframes;
  result->mapped_keyframes = status.mapped_keyframes;
  result->late_keyframes = status.late_keyframes;
  result->spilled_keyframes = status.spilled_keyframes;
  result->push_waits = status.push_waits;
  result->final_stop = status.final_stop;
  result->shortened_keyframes = status.shortened_keyframes;
  result->num_gaussians = status.num_gaussians;
}

}  // namespace dypho
