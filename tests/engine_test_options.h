// EngineOptions for the engine's API tests on small synthetic scenes: full
// resolution training, SH degree 0, no densification, a keyframe at least
// every 4th frame (the frame that triggers it, motion rules only), 20 steps
// per keyframe and 60 final steps, poses from the test (no tracker).
#pragma once

#include "engine/api.h"

namespace dypho::testing {

inline EngineOptions SmallEngineOptions(const Camera& camera, bool synchronous) {
  EngineOptions o;
  o.camera = camera;
  o.mapper.train_downscale = 1;
  o.mapper.sh_degree = 0;
  o.mapper.num_threads = 2;
  o.mapper.densify_every = 0;
  o.keyframes.max_frame_gap = 4;
  o.keyframes.sharpness_window = 1;  // a keyframe is the frame that triggers it (the window has its own test)
  o.keyframes.min_new_content = 0;   // motion rules only (content selection: keyframe_selector_test)
  o.iterations_per_keyframe = 20;
  o.final_iterations = 60;
  o.synchronous = synchronous;
  o.track_when_no_pose = false;
  return o;
}

}  // namespace dypho::testing
