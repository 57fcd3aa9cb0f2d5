// The whole dynamic SLAM system (`dypho run`): DyPho-SLAM's per-frame
// pipeline (../shared/DESIGN.md, "The pipeline, per frame") over a dataset.
//
// Per frame (RunPipeline):
//  1. Read RGB, depth and timestamp (a reader thread reads `prefetch` frames
//     ahead; bounded).
//  2. Predict the pose with constant velocity from the last two poses.
//  3. The map's depth at the predicted pose for the background model:
//     rendered at 1/render_downscale resolution on a helper thread (asked
//     for every render_every frames) and forward-warped to the predicted
//     pose of the frame where it arrives (engine/pipeline/map_depth.h).
//  4. Masks (masking/dynamic_masker.h): raw mask = semantic OR flow motion;
//     background-depth refinement with the rendered depth; the epipolar
//     check of the previous frame's tracker features.
//  5. Track (ORB, with the refined mask, its static weights, epipolar
//     outliers masked, adaptive FAST thresholds), or take the pose from the
//     ground truth or a trajectory file.
//  6. Push the frame with its pose, refined mask and features to the engine
//     (engine/api.h), which decides keyframes and maps them.
//
// Threads: steps 2-6 run on the caller's thread at frame rate; mapping runs
// in the engine's thread behind a bounded keyframe queue (when it falls
// behind the oldest waiting keyframe is dropped and counted); the detector
// runs in its own thread when it has a model (masks carried by the flow
// in between). With options.sequential everything runs on the caller's
// thread and two runs give identical outputs.
//
// Outputs in `out_dir` (every file written atomically):
//   trajectory.txt   world_from_cam per processed frame (TUM format)
//   keyframes.txt    keyframe poses (TUM format)
//   map.ply, map.splat, map.glb, map.spz   the static Gaussian map
//   renders/         keyframe renders beside the real images, renders.png grid
//   overlays/        mask overlays (JPEG) of a sample of frames
//   report.md        ATE/RPE (with ground truth), PSNR/SSIM on static pixels,
//                    per-stage timings, Gaussian count, memory; PNG plots
//   metrics.json     the report's numbers, machine-readable
//   options.yaml     the options used (readable by --config)
// A stop request (e.g. Ctrl-C) ends the frame loop; the outputs are then
// written for the frames processed so far (mapping drains its queue, the
// final refinement is skipped).
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "engine/api.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/ate.h"
#include "engine/eval/trajectory.h"
#include "engine/map/trajectory_follow.h"
#include "engine/pipeline/feature_classes.h"
#include "engine/pipeline/loop_response.h"
#include "engine/pipeline/pipeline_options.h"
#include "engine/pipeline/thread_cpu.h"

namespace dypho {

// Mean per-frame time of each stage [ms].
struct StageTimings {
  double read_ms = 0.0;      // waiting for the frame (decoding runs ahead in the reader thread)
  double render_ms = 0.0;    // map depth at the predicted pose
  double mask_ms = 0.0;      // DynamicMasker::Process (sum of the following and overheads)
  double semantic_ms = 0.0;  // detector run or mask carrying
  double flow_ms = 0.0;      // optical flow and flow-motion mask
  double epipolar_ms = 0.0;  // epipolar check
  double background_ms = 0.0;  // background model and refinement
  double track_ms = 0.0;     // the tracker
  double push_ms = 0.0;      // handing the frame to the engine (mapping too, in sequential mode)
  double frame_ms = 0.0;     // the whole frame on the tracking thread
  // Stereo: the frame loader's disparity of the pair (reader thread, ahead
  // of the frame loop: it shows in read_ms only when the loop waits for it).
  double disparity_ms = 0.0;
};

// Every entry of the output folder a run may write (the built-in sequence's
// "sequence" folder is not among them): RunPipeline clears them first.
inline const std::vector<std::string> kRunOutputs = {
    "options.yaml",  "trajectory.txt",  "keyframes.txt",      "map.ply",     "map.splat",     "map.glb",
    "map.spz",       "report.md",       "metrics.json",       "scores.csv",  "renders.png",   "renders",
    "timings.png",   "backlog.png",     "trajectory_top.png", "error_over_time.png", "overlays", ".waiting_keyframes",
    "dense.ply",     "trajectory_map.txt"};

struct PipelineResult {
  std::string dataset;                 // dataset name
  long frames = 0;                     // frames processed
  long tracked = 0;                    // frames with a pose estimated for them
  long lost = 0;                       // frames without (tracker lost or initialising, no ground truth)
  bool interrupted = false;            // stopped by a stop request (or by an unreadable frame, strict_frames)
  std::vector<size_t> unreadable_frames;  // dataset indices of frames skipped because they could not be read
  std::string stopped_at;              // strict_frames: the read error that ended the run
  Trajectory trajectory;               // world_from_cam per processed frame (lost frames repeat the last pose)
  std::vector<LoopResponseRecord> loops;  // loops the tracker closed and what the maps did (loop_response.h)
  // mapper.refine_poses: how far the keyframes moved against the map; the
  // trajectory follows them (trajectory_follow.h). keyframes 0: not refined.
  FollowStats keyframe_follow;
  // With refine_poses: every frame's pose in the refined map (trajectory_map.txt), the
  // trajectory moved with the keyframes; the map is rendered and scored at these. Empty otherwise.
  Trajectory map_trajectory;
  double map_ate_rmse = 0.0;           // [m] its ATE, when has_ate and map_trajectory is not empty
  bool has_ate = false;
  double ate_rmse = 0.0;               // [m]
  double rpe_translation_rmse = 0.0;   // [m per second], when has_rpe
  double rpe_rotation_rmse = 0.0;      // [deg per second]
  bool has_rpe = false;
  // The map score (engine/eval/map_score.h) at every eval_every-th frame:
  // the plain render at the run's pose against the undistorted frame.
  double psnr = 0.0;                   // [dB] mean over the scored frames
  double ssim = 0.0;
  double depth_l1 = 0.0;               // [m]
  double coverage = 0.0;               // fraction of scored pixels the map covers (alpha > 0.5)
  double psnr_novel = 0.0;             // [dB] over scored frames that are not keyframes (NaN: none)
  double psnr_aligned = 0.0;           // [dB] after a per-frame affine colour fit
  double psnr_sensor = 0.0;            // [dB] through the sensor model (NaN without map_sensor_model)
  double worst_psnr = 0.0;             // [dB]
  int scored_frames = 0;
  int carved_gaussians = 0;            // removed at the end as seen through by other keyframes
  int keyframes = 0;                   // accepted by the engine
  int mapped_keyframes = 0;
  int late_keyframes = 0;              // waited packed or spilled because mapping fell behind (none is dropped)
  int spilled_keyframes = 0;           // of them, spilled to files in the output folder
  int push_waits = 0;                  // frames that waited for room in the keyframe store
  std::string final_stop;              // why the final refinement stopped (converged, steps, time budget, deadline)
  int shortened_keyframes = 0;         // optimised for fewer steps because others were waiting
  int max_backlog = 0;                 // most keyframes waiting at once
  // Stereo: dense disparities computed. The frame loader makes one per
  // frame it loads (the segment starts' look-ahead frames included), at
  // 1/frame_disparity_downscale of the resolution; the engine makes the
  // full one of each keyframe when those are previews (stereo_frames.h).
  int frame_disparities = 0;
  int frame_disparity_downscale = 1;
  int keyframe_disparities = 0;
  double keyframe_disparity_ms = 0.0;  // [ms] mean per keyframe disparity (engine)
  int num_gaussians = 0;
  // The dense point-cloud map (dense.ply): keyframes merged, voxels, memory,
  // and the dense thread's time per keyframe.
  int dense_keyframes = 0;
  long dense_voxels = 0;
  double dense_mb = 0.0;               // [MB] cells and kept keyframe points
  double dense_ms_mean = 0.0, dense_ms_max = 0.0;  // [ms]
  StageTimings timings;                // means per frame
  double tracking_fps = 0.0;           // frames per second of the tracking thread (frames / wall time of the frame loop)
  int detector_results = 0;            // detector runs whose masks reached the frames
  int keyframe_detections = 0;        // detector runs on keyframes whose mask was carried (keyframe_detection)
  double keyframe_detection_ms = 0.0; // [ms] mean time of a keyframe-mask call (on the mapping thread)
  int keyframe_detections_on_push = 0; // of the calls, on the tracking thread (more than 24 keyframes waiting)
  int keyframe_detections_refined = 0; // of the runs, refined against the frame's background depth
  double keyframe_detection_static = 0.0;  // fraction of the refined runs' pixels the refinement made static
  double semantic_age_mean = 0.0;      // frames between the detector's input and the frame using its mask, mean
  int semantic_age_max = 0;            // ... largest
  int map_renders_used = 0;            // map renders that reached the background model
  double map_render_ms = 0.0;          // their mean time on the helper thread (snapshot and render) [ms]
  double map_render_lag = 0.0;         // their mean age when used [frames]
  // Fixed ages (max_mask_age, max_render_age): frames that waited for a
  // late detector result and the time spent waiting, and the same for map renders.
  int mask_lag = 0;                    // frames between a detector run's input and the frame that first uses it (0 = not fixed)
  int mask_look_ahead = 0;             // detector_look_ahead in use: frames read ahead for the detector (0 = none)
  long detector_waits = 0;
  double detector_wait_ms = 0.0;       // [ms] total
  double render_wait_ms = 0.0;         // [ms] total
  std::string mode;                    // which mode ran (sequential / threaded with the ages used / realtime)
  long dropped_frames = 0;             // realtime: frames dropped because a newer one had arrived
  double loop_seconds = 0.0;           // wall time of the frame loop
  // CPU during the frame loop by thread name, in cores (CPU s / loop_seconds);
  // the thread that ran the frame loop is "tracking". Empty off Linux.
  std::vector<ThreadCpuUse> thread_cpu;
  double finish_seconds = 0.0;         // from the last frame until mapping finished (final refinement included)
  int final_iterations = 0;            // steps of the final refinement run (finish_seconds may cut it short)
  double total_seconds = 0.0;          // the whole run incl. outputs
  double mean_mask_fraction = 0.0;     // fraction of pixels masked dynamic, mean over frames
  size_t peak_rss_bytes = 0;
  std::string report_path;             // report.md
};

struct PipelineHooks {
  // Set (e.g. by a SIGINT handler) to stop after the current frame.
  const std::atomic<bool>* stop = nullptr;
  // Called after every frame with (frames done, frames total); may set stop.
  std::function<void(long, long)> on_frame;
  // Called after the ORB tracker ran on a frame, with the frame's dataset
  // index and the positions of the features it extracted [px, input image].
  std::function<void(size_t, const std::vector<Eigen::Vector2f>&)> on_features;
  bool show_progress = true;  // progress lines on stderr
};

// Runs the system over `dataset` and writes the outputs into `out_dir`
// (created). Throws InvalidInput for invalid options, a pose source the
// dataset cannot serve (gt without ground truth), or bad frames.
PipelineResult RunPipeline(const PipelineOptions& options, const Dataset& dataset, const std::string& out_dir,
                           const PipelineHooks& hooks = PipelineHooks());

// The embedding engine's options from the options tree, as `dypho run`
// makes them: the mapper, keyframe policy, iteration counts, waiting
// keyframes, held-back frames and threading of the tree; the sensor model's
// readout is `readout` [s] (the camera's; used only with map_sensor_model);
// waiting keyframes spill to `spill_dir` ("" = none). The pose source and
// depth scale are the caller's (defaults: poses pushed, 5000 per metre).
EngineOptions EngineOptionsFromTree(const PipelineOptions& tree, const Camera& camera, double readout,
                                    const std::string& spill_dir);

// Writes the built-in synthetic sequence into `dir` and opens it: the
// indoor room (options.synth, synth.scene room) or the harbour (synth.scene
// shore: width, height, frames, fps, seed and num_walkers as pedestrians;
// engine/synth/shore/shore_scene.h).
std::unique_ptr<Dataset> MakeBuiltInSequence(const PipelineOptions& options, const std::string& dir);

// The options a dataset's preset gives when the user names none: tum for
// TUM folders, bonn for Bonn, synthetic otherwise.
std::string PresetForDataset(const Dataset& dataset);

// Masking options for images downscaled by n (masking_downscale): pixel
// sizes and thresholds divided by n, areas by n^2, kept within their valid
// ranges; Lucas-Kanade pyramids lose log2(n) levels.
MaskingOptions ScaleMaskingPixels(MaskingOptions options, int n);

// One row of an ablation table.
struct AblationRow {
  std::string name;                   // e.g. "+ mask refinement"
  std::vector<std::string> disabled;  // stages switched off
  PipelineResult result;
  bool has_feature_classes = false;   // the dataset has the harbour's exact class masks
  FeatureClassCounts feature_classes;  // the tracker's features on water, sky, moving things
};

// DyPho-SLAM's ablation: no masking at all; masks without refinement and
// with fixed FAST thresholds; + mask refinement; + adaptive features; the
// full system. With the shore preset, the nearshore paper's rows instead:
// no masks (as plain ORB-SLAM3), shore mask only, shore + semantic, shore +
// semantic + epipolar check. Datasets with the synthetic harbour's class
// masks (water/, sky/) also count the features on them. Each row runs into `out_dir`/<row>/; the table is written to
// `out_dir`/ablation.md and returned.
std::vector<AblationRow> RunAblation(const PipelineOptions& options, const Dataset& dataset,
                                     const std::string& out_dir, const PipelineHooks& hooks = PipelineHooks());

}  // namespace dypho
