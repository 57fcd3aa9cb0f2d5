#include "engine/pipeline/pipeline.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "common/files.h"
#include "common/logging.h"
#include "common/progress.h"
#include "engine/api.h"
#include "engine/eval/plots.h"
#include "engine/eval/report.h"
#include "engine/export/export.h"
#include "engine/io/image_io.h"
#include "engine/map/sensor_model.h"
#include "engine/map/undistort.h"
#include "engine/pipeline/keyframe_detection.h"
#include "engine/pipeline/loop_response.h"
#include "engine/pipeline/finish_mapping.h"
#include "engine/pipeline/frame_masks.h"
#include "engine/pipeline/overlay_writer.h"
#include "engine/pipeline/moving_memory.h"
#include "engine/pipeline/frame_reader.h"
#include "engine/pipeline/live_replay.h"
#include "engine/pipeline/background_prior.h"
#include "engine/pipeline/run_report.h"
#include "common/side_worker.h"
#include "engine/pipeline/stereo_frames.h"
#include "engine/render/render.h"
#include "engine/synth/synthetic_scene.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Lowers the calling thread's priority (Linux nice value of this thread).
void SetThreadNice(int nice) {
  const pid_t tid = static_cast<pid_t>(syscall(SYS_gettid));
  if (setpriority(PRIO_PROCESS, static_cast<id_t>(tid), nice) != 0) {
    DYPHO_LOG(Warning) << "could not set the mapping thread's nice value to " << nice;
  }
}

// Rolling-shutter readout of the Kinect v1 RGB camera (TUM RGB-D), as in
// `dypho track` (estimated on fr1/rpy).
constexpr double kKinectV1Readout = 0.025;

// An owning copy of a CV_8UC1/CV_8UC3 image.
ImageU8 ToImage(const cv::Mat& mat) {
  ImageU8 image(mat.cols, mat.rows, mat.channels());
  const cv::Mat view(mat.rows, mat.cols, mat.type(), image.data());
  mat.copyTo(view);
  return image;
}

}  // namespace

PipelineResult RunPipeline(const PipelineOptions& options, const Dataset& dataset, const std::string& out_dir,
                           const PipelineHooks& hooks) {
  options.Validate();
  const auto run_start = Clock::now();
  struct OpenCvThreads {
    int saved = cv::getNumThreads();
    explicit OpenCvThreads(int n) {
      if (n > 0) cv::setNumThreads(n);
    }
    ~OpenCvThreads() { cv::setNumThreads(saved); }
  } opencv_threads(options.opencv_threads);
  MakeOutputDirectory(out_dir);
  // Outputs of an earlier run in this folder go first: none may sit beside
  // this run's as if it had written them.
  if (ClearOwnedOutputs(out_dir, kRunOutputs) > 0) {
    DYPHO_LOG(Info) << out_dir << ": removed an earlier run's outputs";
  }
  WriteTextAtomically((fs::path(out_dir) / "options.yaml").string(), FormatOptions(options));

  // Pose source.
  enum class Poses { kOrb, kGt, kFile } pose_kind = Poses::kOrb;
  Trajectory pose_file;
  if (options.poses == "gt") {
    DYPHO_CHECK_INPUT(dataset.has_ground_truth())
        << "poses: gt needs a groundtruth.txt in " << dataset.folder() << " (use orb or a trajectory file)";
    pose_kind = Poses::kGt;
  } else if (options.poses != "orb") {
    pose_kind = Poses::kFile;
    pose_file = ReadTumTrajectory(options.poses);
  }

  // Frames.
  std::vector<size_t> indices;
  for (size_t i = static_cast<size_t>(options.first_frame); i < dataset.size(); ++i) {
    if (options.max_frames > 0 && static_cast<long>(indices.size()) >= options.max_frames) break;
    indices.push_back(i);
  }
  DYPHO_CHECK_INPUT(!indices.empty()) << "dataset " << dataset.folder() << " has no frames from first_frame "
                                      << options.first_frame;
  const long total = static_cast<long>(indices.size());
  const Camera& camera = dataset.camera();

  // Components.
  MaskingOptions masking = options.masking;
  bool has_model = !masking.segmenter.model_path.empty() || !masking.segmenter.png_folder.empty();
  if (!has_model && options.semantic && options.semantic_dataset_masks && dataset.frames_with_mask() > 0) {
    masking.segmenter.kind = "png-folder";
    masking.segmenter.png_folder = (fs::path(dataset.folder()) / "masks").string();
    masking.segmenter.png_missing_is_empty = true;
    has_model = true;
  }
  if (options.semantic && !has_model) {
    // The common mistake (issue 15): a dynamic sequence run without a detector, so people pull the tracker.
    const bool flow = masking.use_flow, epipolar = masking.use_epipolar;
    DYPHO_LOG(Warning) << "semantic masks are off: no detector model was given (--model FILE, for example "
                          "../shared/data/models/yolox_nano.onnx); people and other moving objects are caught "
                       << (flow && epipolar ? "only by the flow and epipolar checks"
                           : flow           ? "only by the flow check"
                           : epipolar       ? "only by the epipolar check"
                                            : "by nothing");
  }
  if (!options.semantic || !has_model) {
    masking.segmenter.kind = "none";
    masking.segmenter.model_path.clear();
    masking.segmenter.png_folder.clear();
  }
  // A detector model runs in its own thread; its masks have a fixed age
  // (max_mask_age), threaded or not: a sequential run gets the masks a
  // threaded one does. Masks read from files (a PNG folder, the dataset's
  // masks) take no time: read on the tracking thread, used at once.
  const bool detector_model = options.semantic && !masking.segmenter.model_path.empty();
  masking.schedule.threaded = !options.sequential && detector_model;
  // Reading a recording of RGB-D frames, the detector is handed frames
  // ahead of the tracking thread instead (detector_look_ahead): each
  // detector frame gets its own mask, the others masks 1..interval-1 old.
  const int look_ahead = detector_model && !options.realtime && dataset.stereo() == nullptr
                             ? std::min(options.detector_look_ahead, masking.schedule.interval)
                             : 0;
  masking.schedule.look_ahead = look_ahead;
  if (detector_model && look_ahead == 0)
    masking.schedule.fixed_lag = MaskLagForAge(options.max_mask_age, masking.schedule.interval);
  masking.schedule.debug_delay_ms = options.debug_detector_delay_ms;
  // With a pose prediction the flow stage refines it; the first frames estimate it from the flow.
  const int md = options.masking_downscale;
  FrameMasker frame_masker(masking, camera, md, options.bootstrap_masks);
  const MaskingOptions& mask_options = frame_masker.scaled_options();
  std::unique_ptr<MovingMemory> moving_memory;
  if (options.map_flow_mask == "confirmed" && masking.use_flow)
    moving_memory = std::make_unique<MovingMemory>(options.moving_memory, camera);

  OrbTrackerOptions tracker_options = options.tracker;
  tracker_options.local_ba.threaded = !options.sequential;  // deterministic in sequential mode
  tracker_options.loops.threaded = !options.sequential;
  tracker_options.rolling_shutter_readout =
      options.rolling_shutter >= 0 ? options.rolling_shutter : (dataset.format() == "tum" ? kKinectV1Readout : 0.0);
  EngineOptions engine_options = EngineOptionsFromTree(options, camera, tracker_options.rolling_shutter_readout,
                                                       (fs::path(out_dir) / ".waiting_keyframes").string());
  const StereoFrames stereo_frames(options, dataset, &tracker_options, &engine_options);  // stereo_frames.h
  std::unique_ptr<OrbTracker> tracker;
  if (pose_kind == Poses::kOrb) tracker = std::make_unique<OrbTracker>(camera, tracker_options);
  // The tracker's image-only work (ORB pyramid, blur, main FAST pass) runs
  // here while the tracking thread makes the frame's masks.
  SideWorker side_worker(!options.sequential, "dypho-prepare");
  // Keyframes with a carried semantic mask get a fresh one (keyframe_detection.h).
  std::shared_ptr<KeyframeDetection> keyframe_detection;
  if (options.keyframe_detection && masking.segmenter.kind != "none" &&
      (masking.schedule.interval > 1 || masking.schedule.threaded)) {
    std::optional<BackgroundOptions> refine;
    if (options.keyframe_detection_refine && mask_options.use_background) refine = mask_options.background;
    keyframe_detection = std::make_shared<KeyframeDetection>(mask_options.segmenter, camera, md, refine);
  }
  if (keyframe_detection || options.write_keyframe_masks)
    engine_options.keyframe_mask = KeyframeMaskHook(
        keyframe_detection, options.write_keyframe_masks ? (fs::path(out_dir) / "keyframe_masks").string() : "");
  // The mapping thread inherits the nice value of the thread that creates
  // the engine (Linux: nice is per thread and inherited by new threads, the
  // mapping thread's OpenMP workers included).
  std::unique_ptr<Engine> engine;
  if (!options.sequential && options.mapping_nice > 0) {
    std::exception_ptr error;
    std::thread([&] {
      SetThreadNice(options.mapping_nice);
      try {
        engine = Engine::Create(engine_options);
      } catch (...) {
        error = std::current_exception();
      }
    }).join();
    if (error) std::rethrow_exception(error);
  } else {
    engine = Engine::Create(engine_options);
  }

  kernels::RasterSettings raster;
  raster.sh_degree = options.mapper.sh_degree;
  raster.num_threads = options.mapper.num_threads;
  for (float& b : raster.background) b = options.mapper.background;
  // The background model's prior (background_prior.h).
  BackgroundPrior background(options, engine.get(), camera, raster);
  BackgroundPriorStats prior_stats;

  const std::string overlays_dir = (fs::path(out_dir) / "overlays").string();
  if (options.overlay_every > 0) MakeDirectories(overlays_dir);
  OverlayWriter overlays(!options.sequential);
  const std::string trajectory_path = (fs::path(out_dir) / "trajectory.txt").string();

  // The run's final masks of the frames the map score uses (when the
  // dataset has none of its own).
  std::map<size_t, ImageU8> eval_masks;

  PipelineResult result;
  result.dataset = dataset.name();
  std::vector<FrameRecord> records;
  records.reserve(indices.size());
  std::vector<int> keyframe_positions;  // positions in `records` of keyframes
  LoopResponse loop_response;           // the maps follow the tracker's loop closures (loop_response.h)

  std::optional<Rigid3d> last_pose, prev_pose;  // cam_from_world of the last two frames with a pose
  double last_pose_time = 0.0;                   // timestamp of last_pose [s]
  std::optional<Rigid3d> last_gt;               // for the flow stage in gt mode
  std::vector<cv::Point2f> prev_features;
  double prev_time = -1e300;
  bool last_was_keyframe = false;

  long masker_frame = 0;          // frames given to the masker since its last reset
  long last_semantic_source = -1;  // detector result seen last (masker frame numbers)
  double semantic_age_sum = 0.0;
  long semantic_age_frames = 0;
  Progress progress("run " + dataset.name(), total);
  FrameReader reader(stereo_frames.frames(), indices, options.prefetch);
  // Realtime: frames as a live camera delivers them (live_replay.h).
  std::unique_ptr<LiveReplay> replay;
  if (options.realtime) {
    std::vector<double> timestamps;
    timestamps.reserve(indices.size());
    for (size_t i : indices) timestamps.push_back(dataset.info(i).timestamp);
    replay = std::make_unique<LiveReplay>(std::move(timestamps), options.realtime_speed);
  }
  auto next_frame = [&](long k) { return replay ? replay->Next(k) : k + 1; };
  const auto loop_start = Clock::now();
  const ThreadCpuSnapshot cpu_at_start = ReadThreadCpu();
  double loop_busy_ms = 0.0;
  long prev_k = -1;
  for (long k = next_frame(-1); k >= 0 && k < total; prev_k = k, k = next_frame(k)) {
    if (hooks.show_progress && k > prev_k + 1) progress.Advance(k - prev_k - 1);  // dropped (realtime)
    if (hooks.stop && hooks.stop->load()) {
      result.interrupted = true;
      break;
    }
    FrameRecord rec;
    auto t0 = Clock::now();
    // 1. Read. A frame that cannot be read is skipped (counted in the
    // report); with strict_frames the run ends there as on a stop request.
    Frame frame;
    std::string read_error;
    if (!reader.Get(static_cast<size_t>(k), &frame, &read_error)) {
      if (options.strict_frames) {
        DYPHO_LOG(Error) << "stopping at frame " << indices[static_cast<size_t>(k)]
                         << " (strict_frames): " << read_error;
        result.interrupted = true;
        result.stopped_at = read_error;
        break;
      }
      DYPHO_LOG(Warning) << "frame " << indices[static_cast<size_t>(k)] << " cannot be read, skipped: " << read_error;
      result.unreadable_frames.push_back(indices[static_cast<size_t>(k)]);
      if (hooks.show_progress) progress.Advance(1);
      continue;
    }
    rec.index = frame.index;
    rec.timestamp = frame.timestamp;
    rec.t.read_ms = MsSince(t0);
    rec.t.disparity_ms = frame.disparity_ms;
    if (!frame.right.empty()) ++result.frame_disparities;
    const auto frame_start = Clock::now();
    const bool segment_start = frame.timestamp - prev_time > options.max_gap;
    if (segment_start) {
      masker_frame = 0;
      frame_masker.Reset();
      if (moving_memory) moving_memory->Clear();
      prev_features.clear();
    }
    prev_time = frame.timestamp;
    Awaited<std::shared_ptr<const TrackerPrepared>> prepared;
    if (pose_kind == Poses::kOrb) {
      if (TrackerPrepareJob job = tracker->PrepareJob(CvView(frame.rgb))) prepared = Awaited(side_worker.Submit(job));
    }

    // 2. Predicted pose (constant velocity) and the motion since the last frame.
    std::optional<Rigid3d> predicted, predicted_from_last;
    if (pose_kind == Poses::kGt) {
      if (frame.world_from_cam_gt) predicted = frame.world_from_cam_gt->Inverse();
      if (predicted && last_gt) predicted_from_last = *predicted * last_gt->Inverse();
    } else if (last_pose) {
      predicted = *last_pose;
      if (prev_pose) {
        predicted_from_last = *last_pose * prev_pose->Inverse();
        predicted = *predicted_from_last * *last_pose;
      }
    }

    // 3. The background model's prior at the predicted pose.
    auto t = Clock::now();
    cv::Mat rendered_depth;
    if (masking.use_background && predicted) rendered_depth = background.ForFrame(k, *predicted, &prior_stats);
    rec.t.render_ms = MsSince(t);

    // 4. Masks.
    t = Clock::now();
    const cv::Mat full_rgb = CvView(frame.rgb);
    const std::string frame_name = fs::path(frame.rgb_path).stem().string();
    FrameMaskInput mask_input;
    mask_input.frame = &frame;
    mask_input.segment_start = segment_start;
    mask_input.predicted_from_last = predicted_from_last;
    mask_input.rendered_depth = rendered_depth;
    mask_input.prev_features = prev_features;
    mask_input.keyframe = last_was_keyframe;
    if (look_ahead > 0 && k + look_ahead < total) {
      mask_input.ahead = [&dataset = stereo_frames.frames(), index = indices[static_cast<size_t>(k + look_ahead)]]()
          -> std::optional<Frame> {
        try {
          return dataset.Load(index);
        } catch (const InvalidInput&) {
          return std::nullopt;  // unreadable: skipped with its warning when its turn comes
        }
      };
    }
    Frame next;
    if (frame_masker.WantsNext(segment_start) && frame.has_depth && k + 1 < total) {
      try {
        next = stereo_frames.frames().Load(indices[static_cast<size_t>(k + 1)]);
        if (!next.right.empty()) ++result.frame_disparities;
      } catch (const InvalidInput&) {
        next.has_depth = false;  // unreadable: skipped (with its warning) when its turn comes
      }
      if (next.has_depth && next.timestamp - frame.timestamp <= options.max_gap) mask_input.next = &next;
    }
    MaskResult masks = frame_masker.Process(mask_input);
    rec.t.mask_ms = MsSince(t);
    // Detector: runs that reached the masks, and the age of the semantic
    // mask each frame (frames since the detector's input).
    if (masks.semantic_source_frame >= 0) {
      if (masks.semantic_source_frame != last_semantic_source) ++result.detector_results;
      last_semantic_source = masks.semantic_source_frame;
      const long age = masker_frame - masks.semantic_source_frame;
      semantic_age_sum += age;
      ++semantic_age_frames;
      result.semantic_age_max = std::max<int>(result.semantic_age_max, static_cast<int>(age));
    }
    if (keyframe_detection)
      keyframe_detection->Note(frame.timestamp, frame_name,
                               masks.semantic_source_frame >= 0 && masks.semantic_source_frame == masker_frame,
                               masks.background_depth, masks.background_support);
    ++masker_frame;
    rec.t.semantic_ms = masks.timings.semantic_ms;
    rec.t.flow_ms = masks.timings.flow_ms;
    rec.t.epipolar_ms = masks.timings.epipolar_ms;
    rec.t.background_ms = masks.timings.background_ms;
    rec.mask_fraction = cv::countNonZero(masks.mask) / static_cast<double>(masks.mask.total());

    // The tracker's mask: the refined mask plus discs around epipolar outliers.
    cv::Mat track_mask = masks.mask, track_weight = masks.static_weight;
    if (options.epipolar_radius_px > 0 && !masks.features.dynamic.empty()) {
      track_mask = masks.mask.clone();
      track_weight = masks.static_weight.clone();
      for (size_t f = 0; f < masks.features.dynamic.size(); ++f) {
        if (!masks.features.dynamic[f]) continue;
        cv::circle(track_mask, masks.features.points[f], options.epipolar_radius_px, cv::Scalar(255), cv::FILLED);
        cv::circle(track_weight, masks.features.points[f], options.epipolar_radius_px, cv::Scalar(0), cv::FILLED);
      }
    }

    // 5. Pose.
    t = Clock::now();
    if (options.debug_track_delay_ms > 0)
      std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(options.debug_track_delay_ms));
    std::optional<Rigid3d> pose;
    std::vector<KeyframeFeature> features;
    prev_features.clear();
    if (pose_kind == Poses::kOrb) {
      TrackerFrame tf;
      tf.timestamp = frame.timestamp;
      tf.image = CvView(frame.rgb);
      stereo_frames.SetTrackerInput(frame, &tf);
      tf.dynamic_mask = track_mask;
      tf.static_weight = track_weight;
      if (prepared.valid()) tf.prepared = prepared.get();
      const TrackResult tr = tracker->Track(tf);
      if (IsTracked(tr.status)) pose = tr.cam_from_world;
      if (tr.status == TrackStatus::kLost) {
        DYPHO_LOG(Warning) << "frame " << frame.index << " (t=" << FormatFixed(frame.timestamp, 3)
                           << "): tracking lost: " << tr.message;
      } else if (tr.status == TrackStatus::kRelocalized) {
        DYPHO_LOG(Warning) << "frame " << frame.index << " (t=" << FormatFixed(frame.timestamp, 3)
                           << "): relocalised (" << tr.num_inliers << " inliers)";
      }
      for (const TrackedFeature& f : tr.features) {
        prev_features.emplace_back(f.image_pixel.x(), f.image_pixel.y());
        if (f.depth > 0 && f.weight >= 0.5f) features.push_back({f.pixel.x(), f.pixel.y(), f.depth});
      }
      if (hooks.on_features) {
        std::vector<Eigen::Vector2f> pixels;
        for (const TrackedFeature& f : tr.features) pixels.push_back(f.image_pixel);
        hooks.on_features(frame.index, pixels);
      }
      // The trajectory has a line per frame: lost frames repeat the last pose.
      result.trajectory.Add(frame.timestamp, tr.cam_from_world.Inverse());
      loop_response.NoteFrame(static_cast<long>(frame.index), frame.timestamp, tr, *tracker);
      if (tr.loop_closed || tr.map_restarted) background.PosesMoved();
      if (tr.loop_closed)
        result.loops.push_back(loop_response.Respond(*tracker, engine.get(), &result.trajectory,
                                                     options.loop_refine_iterations));
    } else if (pose_kind == Poses::kGt) {
      pose = predicted;
      if (pose) result.trajectory.Add(frame.timestamp, pose->Inverse());
    } else {
      const std::optional<Rigid3d> world_from_cam = InterpolatePose(pose_file, frame.timestamp, options.max_gap);
      if (world_from_cam) {
        pose = world_from_cam->Inverse();
        result.trajectory.Add(frame.timestamp, *world_from_cam);
      }
    }
    rec.t.track_ms = MsSince(t);
    if (pose_kind == Poses::kGt && frame.world_from_cam_gt) last_gt = frame.world_from_cam_gt->Inverse();

    // 6. Engine: keyframe decision and mapping.
    t = Clock::now();
    last_was_keyframe = false;
    if (pose) {
      ++result.tracked;
      rec.omega = AngularVelocitySince(last_pose, last_pose_time, *pose, frame.timestamp);
      prev_pose = last_pose;
      last_pose = pose;
      last_pose_time = frame.timestamp;
      rec.has_pose = true;
      rec.cam_from_world = *pose;
      FrameBuffers buffers;
      buffers.timestamp = frame.timestamp;
      buffers.angular_velocity = rec.omega;
      buffers.rgb = frame.rgb.data();
      stereo_frames.SetEngineInput(frame, &buffers);
      // The map's mask: the flow-only pixels per map_flow_mask (moving_memory.h).
      const cv::Mat map_mask = MapMask(masks, options.map_flow_mask, moving_memory.get(),
                                       frame.has_depth ? CvView(frame.depth) : cv::Mat(), *pose);
      buffers.dynamic_mask = map_mask.ptr<uint8_t>();
      if (options.map_features) buffers.features = std::move(features);
      if (masking.use_background && frame.has_depth) background.Offer(CvView(frame.depth), masks.mask, *pose);
      const PushResult pushed = engine->PushFrame(buffers, &*pose);
      rec.keyframe = pushed.keyframe;
      if (pushed.keyframe && tracker) loop_response.NoteEngineKeyframe(pushed.keyframe_id, pushed.keyframe_timestamp);
      if (pushed.keyframe && keyframe_detection) keyframe_detection->Claim(pushed.keyframe_timestamp);
      last_was_keyframe = pushed.keyframe;
    } else {
      ++result.lost;
      // Without a pose the velocity model restarts.
      prev_pose.reset();
    }
    rec.t.push_ms = MsSince(t);

    // Outputs during the run: overlays, masks kept for scoring, checkpoints.
    // JPEG: a 640x480 overlay took 12.6 ms as PNG, 1.3 ms as JPEG (4x smaller); drawn on its own thread.
    if (options.overlay_every > 0 && k % options.overlay_every == 0)
      overlays.Write((fs::path(overlays_dir) / (frame_name + ".jpg")).string(), full_rgb, masks);
    if (options.eval_every > 0 && frame.index % options.eval_every == 0 && frame.dynamic_mask.empty())
      eval_masks[frame.index] = ToImage(masks.mask);
    if (options.checkpoint_every > 0 && (k + 1) % options.checkpoint_every == 0 && !result.trajectory.empty())
      WriteTumTrajectory(trajectory_path, result.trajectory);

    const EngineStatus status = engine->QueueStatus();
    rec.backlog = status.queued_keyframes;
    result.max_backlog = std::max(result.max_backlog, rec.backlog);
    rec.t.frame_ms = MsSince(frame_start);
    loop_busy_ms += rec.t.frame_ms;
    if (rec.keyframe) keyframe_positions.push_back(static_cast<int>(records.size()));
    records.push_back(rec);
    ++result.frames;
    if (hooks.show_progress) {
      char extra[160];
      std::snprintf(extra, sizeof(extra), "tracking %.1f fps, keyframes %d, mapping backlog %d, late %d",
                    1000.0 * result.frames / std::max(1e-9, loop_busy_ms), status.keyframes,
                    status.queued_keyframes, status.late_keyframes);
      progress.Advance(1, extra);
    }
    if (hooks.on_frame) hooks.on_frame(result.frames, total);
  }
  overlays.Finish();
  result.loop_seconds = std::chrono::duration<double>(Clock::now() - loop_start).count();
  result.thread_cpu =
      ThreadCpuBetween(cpu_at_start, ReadThreadCpu(), result.loop_seconds, CurrentThreadId(), "tracking");
  if (hooks.show_progress) progress.Finish();
  // Tracking rate: frames over the wall time of the whole frame loop
  // (reading, every stage, outputs during the run and progress included).
  result.tracking_fps = result.loop_seconds > 0 ? result.frames / result.loop_seconds : 0.0;
  if (semantic_age_frames > 0) result.semantic_age_mean = semantic_age_sum / semantic_age_frames;
  result.mask_lag = masking.schedule.fixed_lag;
  result.mask_look_ahead = masking.schedule.look_ahead;
  result.detector_waits = frame_masker.masker().segmenter_waits();
  result.detector_wait_ms = frame_masker.masker().segmenter_wait_ms();
  if (replay) result.dropped_frames = replay->dropped();
  result.mode = RunMode(options, masking);
  result.map_renders_used = prior_stats.used;
  result.render_wait_ms = prior_stats.wait_ms;
  if (prior_stats.used > 0) {
    result.map_render_ms = prior_stats.ms / prior_stats.used;
    result.map_render_lag = prior_stats.lag / prior_stats.used;
  }

  // No pose at all: nothing to map; an empty map or a header-only
  // trajectory would only look like a result.
  DYPHO_CHECK_INPUT(result.tracked > 0 || (result.interrupted && result.stopped_at.empty() && result.frames == 0))
      << "no frame had a pose (" << result.frames << " frames read, " << result.unreadable_frames.size()
      << " unreadable; poses from '" << options.poses << "'"
      << (pose_kind == Poses::kFile ? ": do its timestamps overlap the dataset's?" : "")
      << (result.stopped_at.empty() ? std::string() : "; stopped at an unreadable frame: " + result.stopped_at)
      << "): no map or trajectory written";

  // Mapping: drain the queue; the final refinement unless interrupted.
  const auto finish_start = Clock::now();
  WriteTumTrajectory(trajectory_path, result.trajectory);
  // A map of what is mapped so far, in case the user quits during the final
  // refinement (a second Ctrl-C); replaced below.
  if (engine->Status().num_gaussians > 0) engine->Save(out_dir);
  FinishMapping(engine.get(), options, hooks.show_progress, finish_start, &result);
  const EngineStatus status = engine->Status();
  result.frame_disparity_downscale = stereo_frames.preview_downscale();
  result.keyframe_disparities = status.keyframe_pair_depths;
  if (status.keyframe_pair_depths > 0)
    result.keyframe_disparity_ms = status.keyframe_pair_depth_ms / status.keyframe_pair_depths;
  result.carved_gaussians = status.carved_gaussians;
  // Keyframe detections run on the mapping thread: all done once it is idle.
  if (keyframe_detection) {
    result.keyframe_detections = keyframe_detection->runs();
    result.keyframe_detections_refined = keyframe_detection->refined();
    if (result.keyframe_detections_refined > 0)
      result.keyframe_detection_static = static_cast<double>(keyframe_detection->refined_pixels()) /
                                         (static_cast<double>(result.keyframe_detections_refined) *
                                          (camera.width / md) * (camera.height / md));
  }
  result.keyframe_detection_ms = status.keyframe_masks > 0 ? status.keyframe_mask_ms / status.keyframe_masks : 0.0;
  result.keyframe_detections_on_push = status.keyframe_masks_on_push;

  // Keyframes refined against the map: the other frames follow them in
  // trajectory_map.txt (trajectory.txt keeps the tracker's poses, which do
  // not depend on the mapping thread's progress).
  if (options.mapper.refine_poses && !result.trajectory.empty()) {
    const KeyframeFollow follow(result.trajectory, engine->MappedKeyframes());
    result.map_trajectory = follow.Apply(result.trajectory);
    result.keyframe_follow = follow.stats();
    WriteTumTrajectory((fs::path(out_dir) / "trajectory_map.txt").string(), result.map_trajectory);
  }
  // The report scores the map at the final poses (loop closures and
  // keyframe refinement included), as `dypho score` does with the file.
  SetRecordPoses(result.map_trajectory.empty() ? result.trajectory : result.map_trajectory, &records);

  // The map.
  const GaussianCloud cloud = engine->Map();
  if (cloud.empty()) {
    DYPHO_LOG(Warning) << "the map is empty (no keyframe was mapped): no map files written";
  } else {
    engine->Save(out_dir);  // map.ply, keyframes.txt, dense.ply
    SetDenseResult(engine->DenseStatus(), &result);
    if (options.write_splat) SaveMap(cloud, (fs::path(out_dir) / "map.splat").string());
    if (options.write_glb) SaveMap(cloud, (fs::path(out_dir) / "map.glb").string());
    if (options.write_spz) SaveMap(cloud, (fs::path(out_dir) / "map.spz").string());
  }

  RunReportInputs report_inputs{options,  dataset, out_dir, camera, masking, tracker_options, engine_options,
                                 records,  keyframe_positions, eval_masks, cloud, raster, total, run_start};
  WriteRunOutputs(report_inputs, &result);
  return result;
}

}  // namespace dypho
