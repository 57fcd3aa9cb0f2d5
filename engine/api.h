// dypho's embedding API: use dypho as the mapping backend of another SLAM
// system (or of your own program).
//
// This header has no LibTorch or OpenCV types: frames go in as plain pixel
// buffers, poses as dypho::Rigid3d (Eigen), the map comes out as a
// dypho::GaussianCloud (plain arrays). Link `dypho::engine` after
// `find_package(dypho)`.
//
// Threads. Create() starts one mapping thread. PushFrame copies the frame,
// decides whether it is a keyframe, and hands keyframes to the mapping thread
// through a queue. All methods are safe to call from any thread (for
// instance the host's tracking thread pushes frames while its loop-closure
// thread updates keyframe poses and a viewer thread renders). No keyframe is
// ever dropped: when mapping is slower than the camera, waiting keyframes
// are packed (compressed in memory, engine/map/keyframe_store.h) and, beyond
// EngineOptions::waiting_memory_mb, spilled to files in
// EngineOptions::spill_dir; without a spill folder PushFrame then waits for
// the mapping thread (counted in EngineStatus::push_waits). The map finishes
// after the last frame (Finish). With `synchronous`, PushFrame maps the
// keyframe on the caller's thread before returning: deterministic, for
// tests and batch use.
//
// OpenMP: the rasterizer and LibTorch run OpenMP parallel regions; when the
// host keeps other threads busy, run it with OMP_WAIT_POLICY=passive in the
// environment (the `dypho` program does this itself), otherwise idle OpenMP
// threads spin and slow mapping down several times.
//
// Poses. Pass the frame's pose when the host has one; otherwise the built-in
// ORB tracker estimates it (EngineOptions::track_when_no_pose). Keyframe
// poses can be corrected later (UpdateKeyframePose, e.g. after the host's
// loop closure): the Gaussians inserted from that keyframe move with it.
//
// Errors: bad options, buffers, sizes or non-finite poses throw
// dypho::InvalidInput (common/check.h) naming the field.
//
//   dypho::EngineOptions options;
//   options.camera = {525, 525, 319.5, 239.5, 640, 480};
//   auto engine = dypho::Engine::Create(options);
//   dypho::FrameBuffers frame{timestamp, rgb, depth_u16, nullptr};
//   engine->PushFrame(frame, &cam_from_world);
//   ...
//   engine->Finish();  // waits for the queue, runs the final refinement
//   engine->Save("out");  // map.ply, keyframes.txt
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/rigid3.h"
#include "engine/dense/dense_mapper.h"
#include "engine/dynamic/seen_through.h"
#include "engine/eval/trajectory.h"
#include "engine/gaussians.h"
#include "engine/map/keyframe_selector.h"
#include "engine/map/map_sequence.h"
#include "engine/map/mapper.h"

namespace dypho {

// The frame that becomes a keyframe, as it was pushed (camera size,
// distorted), for EngineOptions::keyframe_mask.
struct KeyframeMaskRequest {
  double timestamp = 0.0;                 // [s]
  int width = 0, height = 0;              // the camera's size
  const uint8_t* rgb = nullptr;           // H x W x 3, RGB
  const float* depth_m = nullptr;         // H x W depth [m], 0 = none
  const uint8_t* dynamic_mask = nullptr;  // H x W, the mask it was pushed with (non-zero = dynamic); null = none
};

struct EngineOptions {
  Camera camera;                    // intrinsics of the pushed frames (distortion allowed: frames are undistorted)
  MapperOptions mapper;             // map model, loss, learning rates, threads (mapper.num_threads)
  KeyframePolicy keyframes;         // when a frame becomes a keyframe
  int iterations_per_keyframe = 40; // optimisation steps after each keyframe
  int final_iterations = 300;       // Finish(): most steps over all keyframes
  double final_seconds = 0.0;       // Finish(): the final refinement stops after this long [s]; 0 = no limit
  // Finish() also stops when the map no longer improves on held-back frames:
  // every `holdout_every`-th frame with depth that is not a keyframe is kept
  // (packed; at most max_holdout_frames, evenly spread), and every
  // finish_check_every steps the mean loss over them is computed; the
  // refinement has converged when finish_patience checks in a row each
  // improved on the best loss so far by less than finish_tolerance
  // (relative), after at least finish_min_steps_per_keyframe steps per
  // keyframe.
  int holdout_every = 0;            // [frames] 0 = no held-back frames (stop on final_iterations/final_seconds only)
  // Finish() first removes Gaussians that at least this many other
  // keyframes see through (Mapper::CarveFreeSpace: missed moving things,
  // floaters); 0 = off.
  int carve_votes = 2;
  int max_holdout_frames = 12;      // held-back frames kept
  int finish_check_every = 100;     // [steps] between held-back checks
  double finish_tolerance = 0.002;  // relative improvement of the held-back loss below which Finish stops
  int finish_patience = 3;          // ... for this many checks in a row, >= 1
  int finish_min_steps_per_keyframe = 40;  // ... and not before this many steps per keyframe, >= 0
  int queue_capacity = 4;           // waiting keyframes kept unpacked; later ones wait packed (never dropped)
  double waiting_memory_mb = 512;   // [MiB] packed waiting keyframes in memory; more go to spill_dir (or PushFrame waits)
  std::string spill_dir;            // folder for waiting keyframes beyond waiting_memory_mb ("" = none: PushFrame waits)
  // When keyframes are waiting, the mapping thread cuts the current
  // keyframe's optimisation short after this many steps (the final
  // refinement makes up for it), so that fewer keyframes are dropped;
  // -1 = always run iterations_per_keyframe steps. Not used when synchronous.
  int min_iterations_when_behind = -1;
  bool synchronous = false;         // map inside PushFrame (deterministic)
  bool track_when_no_pose = true;   // frames pushed without a pose go through the ORB tracker
  double depth_scale = 5000.0;      // depth units per metre for 16-bit depth buffers
  // Stereo pairs (FrameBuffers::right_rgb): the rectified pair's baseline
  // [m] (> 0 accepts pairs; the camera must then have no distortion) and the
  // dense disparity that gives their depth (engine/stereo/disparity.h).
  double stereo_baseline = 0.0;
  std::string stereo_method = "elas";  // elas (ours, ELAS-style) or sgbm (OpenCV)
  int stereo_max_disparity = 128;      // [px] largest disparity searched, 3..255
  // Optional: called for each keyframe before it is mapped, with the frame
  // as pushed, on the mapping thread (synchronous: the pushing thread; when
  // more than 24 keyframes wait for it, the pushing thread asks about the
  // oldest): it must be thread-safe and answer from the frame alone. It
  // returns more dynamic pixels (H x W, non-zero = dynamic; empty = none),
  // which join the frame's dynamic_mask for the map. For a host that runs a
  // detector only every few frames and carries its masks in between (a
  // carried mask misses a person who just came into view): run it again on
  // the keyframes, whose masks decide what enters the map.
  std::function<std::vector<uint8_t>(const KeyframeMaskRequest&)> keyframe_mask;
  // The static dense point-cloud map (engine/dense/dense_mapper.h): built on
  // its own thread from the mapped keyframes, saved as dense.ply.
  DenseMapOptions dense;
  // Keyframe pixels that the frames around the keyframe see through become
  // dynamic (engine/dynamic/seen_through.h): each keyframe is held back for
  // seen_through.window frames before it goes to the mapper. Needs depth.
  SeenThroughOptions seen_through;
  void Validate() const;            // throws InvalidInput naming the field
};

// One RGB-D frame (or a rectified stereo pair) as plain buffers, rows contiguous, camera size.
struct FrameBuffers {
  double timestamp = 0.0;              // [s]
  const uint8_t* rgb = nullptr;        // H x W x 3, RGB order; required
  const uint16_t* depth = nullptr;     // H x W depth in units of depth_scale (0 = none); or
  const float* depth_m = nullptr;      // H x W depth [m] (0 or non-finite = none); at most one of the two
  const uint8_t* dynamic_mask = nullptr;  // H x W, non-zero = dynamic (kept out of the map); optional
  // H x W x 3 RGB: the right image of a rectified stereo pair (rgb is the
  // left); instead of a depth buffer, the engine computes the depth from the
  // pair (EngineOptions::stereo_baseline, stereo_method). Optional.
  const uint8_t* right_rgb = nullptr;
  // With right_rgb and a depth buffer: the depth buffer is a preview (e.g.
  // from the pair at lower resolution) for the per-frame work (keyframe
  // choice, held-out frames), and the dense depth of the pair is computed
  // only for the frames that become keyframes, on the mapping thread
  // (inside PushFrame when synchronous); EngineStatus::keyframe_pair_depths
  // counts them. False: right_rgb and a depth buffer exclude each other.
  bool keyframe_depth_from_pair = false;
  // Tracker features of this frame (undistorted pixels with depth), used to
  // add Gaussians where the map is thin; optional.
  std::vector<KeyframeFeature> features;
  // [rad/s] the camera's rotation rate at this frame (cam_t = Exp(omega t)
  // cam_0), for the rolling-shutter and motion-blur model
  // (EngineOptions::mapper.sensor). Optional: without it the engine
  // differentiates the poses of this frame and the frame pushed before it
  // (when that one had a pose and is less than 0.2 s older; else zero).
  std::optional<Eigen::Vector3d> angular_velocity;
  // [s] when the depth buffer was captured, if not at `timestamp` (the
  // Kinect of TUM fr1 captures depth about 20 ms before its colour image:
  // Dataset's FrameInfo::depth_timestamp). The engine moves the depth to the
  // colour image's pose with the camera's motion between the frame pushed
  // before and this one (else angular_velocity, rotation only). Optional;
  // within 0.1 s of timestamp.
  std::optional<double> depth_timestamp;
};

struct PushResult {
  bool has_pose = false;      // false: no pose (the tracker lost the frame); nothing was mapped
  Rigid3d cam_from_world;     // the pose used (given or tracked)
  // A keyframe was made: the sharpest frame of a short window of frames
  // (KeyframePolicy::sharpness_window), so possibly a frame pushed a few
  // calls before this one; keyframe_timestamp says which.
  bool keyframe = false;
  int keyframe_id = -1;            // its id (ids count 0, 1, ... in order)
  double keyframe_timestamp = 0.0; // [s] the timestamp of the frame that became the keyframe
  std::string message;        // why there is no pose
};

struct EngineStatus {
  int frames = 0;              // frames pushed
  int keyframes = 0;           // keyframes accepted (queued or mapped)
  int mapped_keyframes = 0;    // keyframes inserted into the map
  int queued_keyframes = 0;    // waiting for the mapping thread (held_keyframes included)
  int held_keyframes = 0;      // of them, held back for the frames after them (seen_through; EndOfStream releases them)
  long long seen_through_pixels = 0;  // keyframe pixels made dynamic because other frames see through them
  int late_keyframes = 0;      // keyframes that waited packed or spilled because mapping was behind (none is dropped)
  int spilled_keyframes = 0;   // of them, written to spill_dir
  int push_waits = 0;          // PushFrame calls that waited for room (memory full, no spill folder)
  double peak_waiting_mb = 0;  // [MiB] most memory of packed waiting keyframes
  int shortened_keyframes = 0; // optimised for fewer steps because others were waiting (min_iterations_when_behind)
  int keyframe_pair_depths = 0;     // keyframes whose dense depth the engine computed from the pair (keyframe_depth_from_pair)
  double keyframe_pair_depth_ms = 0; // [ms] their disparity, in total
  int keyframe_masks = 0;           // EngineOptions::keyframe_mask calls so far
  int keyframe_masks_on_push = 0;   // of them, on the pushing thread (too many keyframes waiting)
  double keyframe_mask_ms = 0;      // [ms] time in those calls, in total
  int num_gaussians = 0;
  int iterations = 0;          // optimisation steps so far
  double last_loss = 0.0;
  // The last Finish(): steps run, why it stopped ("converged", "steps",
  // "time budget", "deadline"), and the held-back loss at its start and end.
  int final_steps = 0;
  std::string final_stop;
  int carved_gaussians = 0;    // removed by the free-space check of Finish()
  int holdout_frames = 0;
  double holdout_loss_start = 0.0, holdout_loss_end = 0.0;
};

// A rendered view as plain arrays (row-major).
struct EngineRender {
  int width = 0, height = 0;
  std::vector<float> color;  // H x W x 3, linear [0, 1]
  std::vector<float> depth;  // H x W camera z [m] of what the pixel shows (0 where alpha < 0.5)
  std::vector<float> alpha;  // H x W accumulated opacity
};

class Engine {
 public:
  static std::unique_ptr<Engine> Create(const EngineOptions& options);
  virtual ~Engine() = default;

  // Adds a frame (see the top of this file). `cam_from_world` may be null.
  virtual PushResult PushFrame(const FrameBuffers& frame, const Rigid3d* cam_from_world = nullptr) = 0;
  // Moves keyframe `id` (and its Gaussians) to a corrected pose. A keyframe
  // still waiting in the queue gets the pose before it is mapped.
  virtual void UpdateKeyframePose(int id, const Rigid3d& cam_from_world) = 0;
  // Corrects the pose of the pushed frame with this timestamp while it is
  // the keyframe policy's kept candidate (not emitted yet); it is emitted
  // later with the corrected pose. Returns whether it was the candidate.
  virtual bool UpdateCandidatePose(double timestamp, const Rigid3d& cam_from_world) = 0;
  // Runs `steps` optimisation steps over the mapped keyframes now (e.g.
  // after a loop closure moved keyframes), on the caller's thread, one step
  // per map lock; with the mapping thread busy they interleave with its
  // steps. Returns the steps run (0 while nothing is mapped).
  virtual int Refine(int steps) = 0;
  // The same steps on the mapping thread: returns at once (a loop closure
  // need not stall the caller's tracking). The steps run before the next
  // queued keyframe is inserted; WaitUntilIdle and Finish wait for them. A
  // synchronous engine runs them now, as Refine. Returns the steps run now
  // (synchronous) or scheduled.
  virtual int RequestRefine(int steps) = 0;
  // The current pose of keyframe `id` (after updates and refinement).
  virtual Rigid3d KeyframePose(int id) const = 0;
  // The keyframes in the map now: their timestamps and poses
  // (world_from_cam, after updates and refinement), in the order they were
  // mapped; what Save writes to keyframes.txt.
  virtual Trajectory MappedKeyframes() const = 0;
  // Renders the current map at any pose with any pinhole intrinsics
  // (`camera`'s distortion is ignored).
  virtual EngineRender Render(const Camera& camera, const Rigid3d& cam_from_world,
                              kernels::CompositeMode mode = kernels::CompositeMode::kSorted) const = 0;
  // A copy of the current map.
  virtual GaussianCloud Map() const = 0;
  virtual EngineStatus Status() const = 0;
  // The queue side of Status without waiting for the map: frames, keyframes,
  // queued_keyframes, the late/spilled counts and mapped_keyframes are filled, the
  // map fields (num_gaussians, iterations, last_loss) are left 0. Status()
  // waits for the current optimisation step; this never does, so a
  // tracking thread can poll it every frame.
  virtual EngineStatus QueueStatus() const = 0;
  // The frames have ended: a keyframe candidate still waiting for the end of
  // its sharpness window becomes a keyframe now, and keyframes held for the
  // frames after them (seen_through) go to the mapper (Finish does this too;
  // call it before waiting for the queue to empty, or when stopping early
  // without Finish).
  virtual void EndOfStream() = 0;
  // Blocks until every queued keyframe is mapped.
  virtual void WaitUntilIdle() = 0;
  // WaitUntilIdle, then the final refinement (EngineOptions::final_iterations
  // steps, or fewer when the held-back loss has converged, when
  // EngineOptions::final_seconds runs out or `deadline` passes; a deadline
  // already past means no steps). `progress`, when given, is called every few
  // steps with the steps done and planned. Returns the steps run; Status()
  // tells why it stopped.
  virtual int Finish(const std::function<void(int done, int planned)>& progress = {},
                     std::optional<std::chrono::steady_clock::time_point> deadline = std::nullopt) = 0;
  // Writes `dir`/map.ply (3DGS PLY), `dir`/keyframes.txt (keyframe poses,
  // TUM format) and, with the dense map on, `dir`/dense.ply (SaveDenseCloud),
  // atomically. Safe while mapping runs (a consistent snapshot).
  virtual void Save(const std::string& dir) const = 0;
  // Writes the static dense point cloud of the mapped keyframes (binary PLY:
  // x y z, nx ny nz, red green blue; world frame), atomically, at the
  // keyframes' current poses (refined or corrected poses move their points).
  // Keyframes still waiting for the mapper are not in it yet. Throws
  // InvalidInput when EngineOptions.dense.enabled is false or on a write error.
  virtual void SaveDenseCloud(const std::string& path) const = 0;
  // The dense map's counters (keyframes, voxels, memory, time per keyframe);
  // all zero when it is off.
  virtual DenseMapStats DenseStatus() const = 0;
};

}  // namespace dypho
