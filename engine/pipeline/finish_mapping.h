// The end of a run (dypho run): the queued keyframes mapped, then the
// final refinement within its budget (or, after an interrupt, only the
// queue), with progress lines; the engine's counts copied into the result.
#pragma once

#include <chrono>

#include "engine/api.h"
#include "engine/pipeline/pipeline.h"

namespace dypho {

// `finish_start`: when the frame loop ended (the budget's clock).
// Fills result->final_iterations, finish_seconds and the engine status
// fields (keyframes, late, spilled, Gaussians, ...).
void FinishMapping(Engine* engine, const PipelineOptions& options, bool show_progress,
                   std::chrono::steady_clock::time_point finish_start, PipelineResult* result);

}  // namespace dypho
