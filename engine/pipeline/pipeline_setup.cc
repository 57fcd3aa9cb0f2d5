// The pipeline's setup functions declared in pipeline.h: the preset of a
// dataset, the engine's options from the options tree (the built-in sequence is
// builtin_sequence.cc).
#include "engine/pipeline/pipeline.h"

#include "common/check.h"

namespace dypho {

std::string PresetForDataset(const Dataset& dataset) {
  if (dataset.format() == "tum") return "tum";
  if (dataset.format() == "bonn") return "bonn";
  if (dataset.stereo() != nullptr) return "stereo";
  return "synthetic";
}

EngineOptions EngineOptionsFromTree(const PipelineOptions& tree, const Camera& camera, double readout,
                                    const std::string& spill_dir) {
  EngineOptions o;
  o.camera = camera;
  o.mapper = tree.mapper;
  // The sensor model's readout is the camera's (the tracker's) readout.
  SensorModel& sensor = o.mapper.sensor;
  sensor.readout = readout;
  if (!tree.map_sensor_model) sensor = SensorModel();
  o.keyframes = tree.keyframes;
  o.iterations_per_keyframe = tree.iterations_per_keyframe;
  o.final_iterations = tree.final_iterations;
  o.queue_capacity = tree.queue_capacity;
  o.waiting_memory_mb = tree.waiting_memory_mb;
  o.spill_dir = spill_dir;
  o.carve_votes = tree.carve_votes;
  o.dense = tree.dense;
  o.seen_through = tree.seen_through;
  o.seen_through.readout = readout;  // the camera's rolling shutter
  o.holdout_every = tree.holdout_every;
  o.max_holdout_frames = tree.max_holdout_frames;
  o.finish_check_every = tree.finish_check_every;
  o.finish_tolerance = tree.finish_tolerance;
  o.finish_patience = tree.finish_patience;
  o.finish_min_steps_per_keyframe = tree.finish_min_steps_per_keyframe;
  o.min_iterations_when_behind = tree.min_iterations_when_behind;
  o.synchronous = tree.sequential;
  o.track_when_no_pose = false;
  return o;
}

}  // namespace dypho
