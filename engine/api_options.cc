// EngineOptions::Validate (engine/api.h).
#include <cmath>
#include <string>

#include "common/check.h"
#include "engine/api.h"

namespace dypho {

void EngineOptions::Validate() const {
  std::string error;
  DYPHO_CHECK_INPUT(camera.IsValid(&error)) << "EngineOptions.camera: " << error;
  mapper.Validate();
  keyframes.Validate();
  if (seen_through.enabled) seen_through.Validate();
  DYPHO_CHECK_INPUT(iterations_per_keyframe >= 0)
      << "EngineOptions.iterations_per_keyframe must be >= 0 (got " << iterations_per_keyframe << ")";
  DYPHO_CHECK_INPUT(final_iterations >= 0) << "EngineOptions.final_iterations must be >= 0 (got " << final_iterations << ")";
  DYPHO_CHECK_INPUT(std::isfinite(final_seconds) && final_seconds >= 0)
      << "EngineOptions.final_seconds must be >= 0 (got " << final_seconds << ")";
  DYPHO_CHECK_INPUT(queue_capacity >= 1) << "EngineOptions.queue_capacity must be >= 1 (got " << queue_capacity << ")";
  DYPHO_CHECK_INPUT(std::isfinite(waiting_memory_mb) && waiting_memory_mb >= 1)
      << "EngineOptions.waiting_memory_mb must be >= 1 MiB (got " << waiting_memory_mb << ")";
  DYPHO_CHECK_INPUT(carve_votes >= 0) << "EngineOptions.carve_votes must be >= 0 (got " << carve_votes << ")";
  DYPHO_CHECK_INPUT(holdout_every >= 0) << "EngineOptions.holdout_every must be >= 0 (got " << holdout_every << ")";
  DYPHO_CHECK_INPUT(max_holdout_frames >= 1)
      << "EngineOptions.max_holdout_frames must be >= 1 (got " << max_holdout_frames << ")";
  DYPHO_CHECK_INPUT(finish_check_every >= 1)
      << "EngineOptions.finish_check_every must be >= 1 (got " << finish_check_every << ")";
  DYPHO_CHECK_INPUT(std::isfinite(finish_tolerance) && finish_tolerance >= 0)
      << "EngineOptions.finish_tolerance must be >= 0 (got " << finish_tolerance << ")";
  DYPHO_CHECK_INPUT(finish_patience >= 1)
      << "EngineOptions.finish_patience must be >= 1 (got " << finish_patience << ")";
  DYPHO_CHECK_INPUT(finish_min_steps_per_keyframe >= 0)
      << "EngineOptions.finish_min_steps_per_keyframe must be >= 0 (got " << finish_min_steps_per_keyframe << ")";
  DYPHO_CHECK_INPUT(std::isfinite(depth_scale) && depth_scale > 0)
      << "EngineOptions.depth_scale must be > 0 (got " << depth_scale << ")";
  if (dense.enabled) dense.Validate();
  DYPHO_CHECK_INPUT(std::isfinite(stereo_baseline) && stereo_baseline >= 0)
      << "EngineOptions.stereo_baseline must be >= 0 m (got " << stereo_baseline << ")";
  DYPHO_CHECK_INPUT(stereo_method == "elas" || stereo_method == "sgbm")
      << "EngineOptions.stereo_method must be elas or sgbm (got '" << stereo_method << "')";
  DYPHO_CHECK_INPUT(stereo_max_disparity >= 3 && stereo_max_disparity <= 255)
      << "EngineOptions.stereo_max_disparity must be in [3, 255] (got " << stereo_max_disparity << ")";
  DYPHO_CHECK_INPUT(stereo_baseline == 0 || !camera.HasDistortion())
      << "EngineOptions.stereo_baseline: stereo pairs must be rectified, but EngineOptions.camera has distortion";
}

}  // namespace dypho
