// The options tree of the whole system (`dypho run`): one struct that holds
// every component's options (masking, tracker, mapper, keyframes) plus the
// pipeline's own, a flat table of every parameter with its key, default,
// units and range (DescribeOptions), presets, and reading from YAML or JSON.
//
// Keys are dotted paths: "masking.flow.scale", "tracker.min_inliers",
// "mapper.lr_means". A config file is a nested map of the same keys (or
// flat dotted keys); JSON files are read by the same parser. A file may
// name a preset ("preset: tum"); the preset is applied first, then the
// file's other keys, then command-line overrides ("--set key=value").
// Unknown keys, values of the wrong type and values out of range throw
// InvalidInput naming the key (and the file).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "engine/dense/dense_mapper.h"
#include "engine/dynamic/seen_through.h"
#include "engine/map/map_sequence.h"
#include "engine/map/mapper.h"
#include "engine/pipeline/frame_depth_prior.h"
#include "engine/pipeline/moving_memory.h"
#include "engine/synth/synth_options.h"
#include "masking/dynamic_masker.h"
#include "tracker/orb_tracker.h"

namespace dypho {

struct PipelineOptions {
  std::string preset = "synthetic";  // the preset the options started from (synthetic|tum|bonn|shore|stereo)
  // Poses.
  std::string poses = "orb";         // orb (the ORB tracker) | gt (the dataset's ground truth) | a TUM trajectory file
  double rolling_shutter = -1.0;     // RGB rolling-shutter readout [s]; -1 = auto (0.025 for TUM folders, else 0)
  // Frames.
  long first_frame = 0;              // first dataset frame used, >= 0
  long max_frames = 0;               // frames processed (0 = all), >= 0
  double max_gap = 0.5;              // frames further apart than this restart the masks [s], > 0
  // Threads.
  bool sequential = false;           // mapping and the detector on the tracking thread: identical results run to run
  // Threaded mode: the asynchronous inputs of a frame have a fixed age, so
  // that a slower machine gives the same masks later instead of other masks
  // now (masking/async_segmenter.h, engine/pipeline/map_depth.h). A frame
  // waits for a result that is late. 0 = the newest result whenever it
  // arrives (the masks then depend on timing).
  int max_mask_age = 5;              // the detector's masks are at most this many frames old, 0 or masking.schedule.interval..1000
  // Reading recorded RGB-D frames with a detector model: the detector gets
  // the frame this many frames ahead (at most masking.schedule.interval),
  // so that its frames get their own masks, age 0, and the tracking thread
  // rarely waits; 0 = the fixed lag of max_mask_age. Not with realtime or
  // stereo pairs (max_mask_age applies there). 0..1000.
  int detector_look_ahead = 3;
  int max_render_age = 6;            // the map's background depth reaches the frame this many frames after it was asked for, 0..1000
  // Test hooks: the detector thread, the map-render thread and the tracking
  // thread sleep this long per run / render / frame [ms], 0..60000.
  double debug_detector_delay_ms = 0.0;
  double debug_render_delay_ms = 0.0;
  double debug_track_delay_ms = 0.0;
  // Replays the dataset at its own timestamps (times realtime_speed) as a
  // live camera delivers it: when the tracking thread takes the next frame,
  // it gets the newest one that has arrived and the ones before it are
  // dropped (counted in the report); it waits for a frame not arrived yet.
  bool realtime = false;
  double realtime_speed = 1.0;       // replay rate: 1 = the dataset's own, 0.5 = half speed, (0, 100]
  // A frame that cannot be read ends the run as a stop request does (outputs
  // written for the frames before it) instead of being skipped with a warning.
  bool strict_frames = false;
  int prefetch = 2;                  // frames read ahead by the reader thread (0 = read on the tracking thread), 0..8
  int queue_capacity = 4;            // waiting keyframes kept unpacked (later ones wait packed; none is dropped), >= 1
  // Packed waiting keyframes take at most this much memory [MiB]; more are
  // spilled to files in the output folder (.waiting_keyframes/, removed at
  // the end), >= 1.
  double waiting_memory_mb = 512;
  int min_iterations_when_behind = 10;  // with keyframes waiting, a keyframe's optimisation stops after this many steps (-1 = never)
  // Linux nice value of the mapping thread and the map-depth render thread
  // (0 = the tracking thread's priority): on a machine with few cores they
  // then take the time the tracking and detector threads leave, 0..19. 19
  // rather than 10: walkers s23 / s11 tracked at 30.8-34.3 frames/s against
  // 29.8-30.9 (26.5 against 24.0 with a core busy), the same trajectories,
  // and the clean head250 map as good and finished sooner (BENCHMARKS).
  int mapping_nice = 19;
  // OpenCV's worker threads (cv::setNumThreads) while the run lasts; 0 =
  // OpenCV's default (all cores). With one, the tracking thread's OpenCV
  // calls (flow, masks, ORB) do not wait for a worker that the mapping
  // thread has descheduled, 0..64.
  int opencv_threads = 1;
  // Stages (the ablation switches).
  bool semantic = true;              // semantic mask from the detector (needs masking.segmenter.model_path or png_folder)
  // Without a model or PNG folder, the dataset's own masks/ folder (the synthetic generator's exact masks) stands
  // in for the detector's output, run on the detector's schedule (masking.schedule.interval) and carried by the
  // flow in between. For synthetic data only: YOLOX does not recognise the generator's box figures.
  bool semantic_dataset_masks = false;
  // The background depth render at the predicted pose.
  int render_downscale = 2;          // the map is rendered at 1/n resolution for the background model, 1..8
  // The render is made on a helper thread and warped to the predicted pose of
  // the frame where it arrives (engine/pipeline/map_depth.h); the background
  // model carries its background between renders.
  int render_every = 3;              // ask for a render of the map every n frames (at most one in flight), >= 1
  // The background model's prior: "frames" (default): earlier frames' depth
  // outside their masks where several agree, warped on the tracking thread
  // every render_every frames (engine/pipeline/frame_depth_prior.h); it does
  // not depend on the mapping thread's progress, so a threaded run gives
  // the sequential run's masks and trajectory. "map": the map's renders
  // above (their content depends on how far the mapping thread has got).
  // Walkers on head250, 7 sequences not used to choose the prior's options:
  // ATE 1.60 cm mean with frames, 2.17 cm (mean of 2 runs each) with map
  // (BENCHMARKS "Sequential = threaded").
  std::string background_prior = "frames";
  FrameDepthPriorOptions frame_prior;
  // The masks are computed at 1/n resolution (pixel options of masking.*
  // are scaled to it; they stay in pixels of the full image) and the final
  // mask is upsampled for the tracker and the mapper.
  int masking_downscale = 1;         // 1..4
  int epipolar_radius_px = 6;        // features flagged by the epipolar check mask a disc of this radius for the tracker [px], 0..50
  bool map_features = true;          // tracker features with depth densify the map
  bool bootstrap_masks = true;       // the first frame's flow mask is taken from the flow to the second frame
  // A keyframe whose semantic mask was carried from an earlier detector run
  // (masking.schedule.interval > 1, or the detector thread) gets the detector
  // run on it again before it is mapped (EngineOptions::keyframe_mask): a
  // carried mask misses people who came into view since that run.
  bool keyframe_detection = true;
  // ... and that fresh mask is refined against the frame's background depth
  // (keyframe_detection.h): its pixels that agree with a supported
  // background are static.
  bool keyframe_detection_refine = true;
  // Which flow-only pixels (flow-motion mask outside the semantic mask) the
  // map leaves out (moving_memory.h): "all", "none", or "confirmed": the
  // components near where the detector saw movers in the last frames. The
  // tracker and the background model use the whole mask in every case.
  std::string map_flow_mask = "all";
  MovingMemoryOptions moving_memory;
  // Stereo datasets: the tracker takes its features' depth from the pair by
  // sparse matching (tracker/stereo/stereo_features.h) instead of the dense
  // disparity, which only the map uses.
  bool sparse_stereo_tracking = true;
  // Stereo with sparse_stereo_tracking: the frame loader's depth is a preview
  // from the pair at 1/n resolution (masks, keyframe choice) and the engine
  // computes the full dense depth of keyframes only (stereo_frames.h);
  // 1 = the full dense depth of every frame in the loader.
  int stereo_preview_downscale = 2;
  // Stereo with previews: the tracker searches its features' matches in the
  // right image around the preview's disparity (no right-image ORB features;
  // StereoFeatureDepthsFromPrior) instead of matching right-image features
  // (on in the stereo preset).
  bool stereo_prior_tracking = false;
  // Mapping.
  MapperOptions mapper;              // mapper.* (mapper.sensor.readout is set from rolling_shutter, see below)
  // The mapper renders through the camera's rolling shutter (readout =
  // rolling_shutter, resolved) and motion blur (mapper.sensor.exposure), with
  // each keyframe's angular velocity from the poses (engine/map/sensor_model.h);
  // scoring applies the same model to the renders.
  bool map_sensor_model = false;
  KeyframePolicy keyframes;          // keyframes.*
  int iterations_per_keyframe = 40;  // optimisation steps after each keyframe, >= 0
  int final_iterations = 300;        // steps over all keyframes after the last frame, >= 0
  int loop_refine_iterations = 30;   // steps right after a loop closure moved the keyframes, >= 0
  // Mapping after the last frame: the queued keyframes are always mapped; the
  // final refinement then stops when this much time has passed since the
  // last frame (0 = no limit) [s], >= 0.
  double finish_seconds = 100.0;
  // The final refinement also stops when the map stops improving on
  // held-back frames (every holdout_every-th frame that is not a keyframe,
  // at most max_holdout_frames; checked every finish_check_every steps;
  // finish_patience checks in a row below finish_tolerance of the best loss
  // so far end it, not before finish_min_steps_per_keyframe steps per
  // keyframe). 0 = off.
  // The dense point-cloud map (dense.ply), dense.*: its depth range and
  // voxel size (defaults for indoor RGB-D: 0.1-4 m, 2 cm voxels).
  DenseMapOptions dense;
  // Keyframe pixels the frames around a keyframe see through are dynamic
  // (seen_through.*, engine/dynamic/seen_through.h).
  SeenThroughOptions seen_through;
  int carve_votes = 2;               // Finish removes Gaussians this many other keyframes see through (0 = off)
  int holdout_every = 10;
  int max_holdout_frames = 12;
  int finish_check_every = 100;
  double finish_tolerance = 0.002;
  int finish_patience = 3;
  int finish_min_steps_per_keyframe = 40;
  // Components.
  MaskingOptions masking;            // masking.*
  OrbTrackerOptions tracker;         // tracker.*
  // Outputs.
  bool write_keyframe_masks = false;  // each keyframe's final mask as OUT/keyframe_masks/<timestamp>.png
  int overlay_every = 10;            // mask overlay JPEG every n frames (0 = none), >= 0
  int keyframe_renders = 8;          // keyframes rendered beside the real image in renders/, >= 0
  int eval_every = 10;               // the map is scored at every n-th frame (dypho score's protocol; 0 = not scored), >= 0
  int eval_downscale = 1;            // PSNR/SSIM renders at 1/n resolution, 1..8
  bool write_splat = true;           // map.splat beside map.ply
  bool write_glb = true;             // map.glb beside map.ply
  bool write_spz = true;             // map.spz (compressed, engine/export/spz.h) beside map.ply
  int checkpoint_every = 30;         // the trajectory is rewritten every n frames during the run (0 = only at the end), >= 0
  // The built-in synthetic dynamic sequence (no DATASET given).
  SynthOptions synth;                // synth.*
  std::string synth_scene = "room";  // synth.scene: room (indoor, SynthOptions) | shore (the harbour)
  std::string synth_motion = "xyz";  // synth.motion: xyz|rpy|halfsphere|static|loop

  PipelineOptions();
  // Throws InvalidInput naming the key of the first invalid value (table
  // ranges, then each component's own checks).
  void Validate() const;
};

// One parameter of the tree.
struct OptionInfo {
  std::string key;            // dotted key
  std::string type;           // int | float | bool | string | list
  std::string units;          // e.g. "m", "px", "" when unitless
  std::string doc;            // one line
  double min = 0.0, max = 0.0;  // inclusive range for numbers (has_range)
  bool has_range = false;
  std::function<std::string()> get;         // the current value as text
  std::function<void(const std::string&)> set;  // parses text; throws InvalidInput naming the key
};

// Every parameter of `options` (the functions refer to it).
std::vector<OptionInfo> DescribeOptions(PipelineOptions* options);

// Names of the presets, and applying one (throws naming the preset).
std::vector<std::string> PresetNames();
// The preset's own settings as YAML text (on top of the defaults).
std::string PresetText(const std::string& name);
PipelineOptions PresetOptions(const std::string& name);

// Sets one key from text ("masking.flow.scale", "0.25"). Throws InvalidInput
// naming the key when it is unknown or the value does not parse or is out of
// range. `origin` (e.g. the file) prefixes the message.
void SetOption(PipelineOptions* options, const std::string& key, const std::string& value,
               const std::string& origin = "");
// "key=value" as given to --set.
void SetOptionAssignment(PipelineOptions* options, const std::string& assignment);
// Applies YAML/JSON text: a "preset" key first (replacing `options` with the
// preset), then every other key. `origin` names the source in messages.
void ApplyConfigText(PipelineOptions* options, const std::string& text, const std::string& origin);
// Reads a .yaml/.yml/.json file with ApplyConfigText.
void ApplyConfigFile(PipelineOptions* options, const std::string& path);

// The whole tree as YAML, one "key: value  # units, range: doc" line per
// parameter, nested by section (what `dypho run --print-config` prints;
// readable again by ApplyConfigText).
std::string FormatOptions(PipelineOptions options);

// The ablation switches of `--disable`: refine, adaptive, semantic, flow,
// epipolar, and "masking" (all of them and the masks altogether).
std::vector<std::string> AblationSwitches();
void DisableStage(PipelineOptions* options, const std::string& stage);

}  // namespace dypho
