// Options for pipeline tests that only look at poses, masks or the map:
// no time-limited finish and none of the extra outputs (.glb, .spz,
// .splat, keyframe renders, overlays, the map score).
#pragma once

#include "engine/pipeline/pipeline_options.h"

namespace dypho::testing {

inline void SkipExtraOutputs(PipelineOptions* o) {
  o->finish_seconds = 0;
  o->write_glb = o->write_spz = o->write_splat = false;
  o->keyframe_renders = 0;
  o->overlay_every = 0;
  o->eval_every = 0;
}

}  // namespace dypho::testing
