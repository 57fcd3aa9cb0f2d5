// MakeBuiltInSequence (engine/pipeline/pipeline.h): the sequence `dypho run`
// generates when no dataset is given.
#include "common/check.h"
#include "engine/pipeline/pipeline.h"
#include "engine/synth/shore/shore_scene.h"
#include "engine/synth/synthetic_scene.h"

namespace dypho {

std::unique_ptr<Dataset> MakeBuiltInSequence(const PipelineOptions& options, const std::string& dir) {
  if (options.synth_scene == "shore") {
    ShoreSynthOptions shore;
    shore.width = options.synth.width;
    shore.height = options.synth.height;
    shore.frames = options.synth.frames;
    shore.fps = options.synth.fps;
    shore.seed = options.synth.seed;
    shore.num_pedestrians = options.synth.num_walkers;
    WriteShoreSequence(shore, dir);
    return OpenDataset(dir);
  }
  DYPHO_CHECK_INPUT(options.synth_scene == "room") << "synth.scene: '" << options.synth_scene << "' is unknown";
  SynthOptions synth = options.synth;
  DYPHO_CHECK_INPUT(ParseSynthMotion(options.synth_motion, &synth.motion))
      << "synth.motion: '" << options.synth_motion << "' is unknown";
  WriteSyntheticSequence(synth, dir);
  return OpenDataset(dir);
}

}  // namespace dypho
