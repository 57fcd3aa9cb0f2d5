#include "engine/pipeline/run_report.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "common/files.h"
#include "common/logging.h"
#include "engine/eval/ate.h"
#include "engine/eval/map_score.h"
#include "engine/eval/plots.h"
#include "engine/eval/report.h"
#include "engine/map/map_sequence.h"
#include "engine/map/undistort.h"
#include "engine/render/render.h"
#include "tracker/cv_view.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
std::string Fmt(double v, int decimals) { return FormatFixed(v, decimals); }

ImageU8 ColorToU8(const ImageF& color) {
  ImageU8 out(color.width(), color.height(), 3);
  for (size_t i = 0; i < out.size(); ++i)
    out.data()[i] = static_cast<uint8_t>(std::clamp(color.data()[i], 0.0f, 1.0f) * 255.0f + 0.5f);
  return out;
}

}  // namespace

// Which mode ran, for the report: sequential, or threaded with the ages of
// its asynchronous inputs; realtime replay.
std::string RunMode(const PipelineOptions& options, const MaskingOptions& masking) {
  std::ostringstream out;
  const bool seq = options.sequential;
  out << (seq ? "sequential (deterministic; " : "threaded (");
  const int lag = masking.schedule.fixed_lag;
  const int ahead = masking.schedule.look_ahead;
  if (ahead > 0)
    out << "detector " << ahead << " frames ahead: its frames' own masks, others 1.." << masking.schedule.interval - 1
        << " frames old";
  else if (lag > 0)
    out << "detector masks " << lag << ".." << std::max(masking.schedule.interval, lag) + lag - 1
        << " frames old (max_mask_age " << options.max_mask_age << ")";
  else if (!masking.schedule.threaded)
    out << (seq ? "detector on the tracking thread" : "no detector thread");
  else
    out << "detector masks: newest result (timing-dependent)";
  out << "; ";
  if (!masking.use_background)
    out << "no background model";
  else if (options.background_prior == "frames")
    out << "background prior from earlier frames";
  else if (seq)
    out << "map renders at once";
  else if (options.max_render_age > 0)
    out << "map renders " << options.max_render_age << " frames old (max_render_age; their content depends on the mapping thread)";
  else
    out << "map renders: newest (timing-dependent)";
  const bool orb = options.poses == "orb";
  if (orb && options.tracker.local_ba.enabled) {
    if (options.tracker.local_ba.fixed_lag > 0)
      out << "; local BA applied " << options.tracker.local_ba.fixed_lag << " frames after its keyframe";
    else
      out << (seq ? "; local BA applied at once" : "; local BA: when ready (timing-dependent)");
  }
  if (orb && options.tracker.loops.enabled) {
    if (options.tracker.loops.fixed_lag > 0)
      out << "; loop closures applied " << options.tracker.loops.fixed_lag << " frames after their keyframe";
    else
      out << (seq ? "; loop closures applied at once" : "; loop closures: when ready (timing-dependent)");
  }
  out << ")";
  if (options.realtime) out << ", realtime replay at " << FormatFixed(options.realtime_speed, 2) << "x";
  return out.str();
}

void SetDenseResult(const DenseMapStats& dense, PipelineResult* result) {
  result->dense_keyframes = dense.keyframes_added;
  result->dense_voxels = static_cast<long>(dense.map.voxels);
  result->dense_mb = dense.map.bytes / 1e6;
  result->dense_ms_mean = dense.mean_ms();
  result->dense_ms_max = dense.max_ms;
}

void SetRecordPoses(const Trajectory& trajectory, std::vector<FrameRecord>* records) {
  size_t line = 0;  // both in time order
  for (FrameRecord& r : *records) {
    if (!r.has_pose) continue;
    while (line < trajectory.size() && trajectory.timestamps[line] < r.timestamp - 1e-9) ++line;
    if (line < trajectory.size() && std::abs(trajectory.timestamps[line] - r.timestamp) <= 1e-9)
      r.cam_from_world = trajectory.world_from_cam[line].Inverse();
  }
}

void WriteRunOutputs(const RunReportInputs& in, PipelineResult* out) {
  using Clock = std::chrono::steady_clock;
  const PipelineOptions& options = in.options;
  const Dataset& dataset = in.dataset;
  const std::string& out_dir = in.out_dir;
  const Camera& camera = in.camera;
  const MaskingOptions& masking = in.masking;
  const OrbTrackerOptions& tracker_options = in.tracker_options;
  const EngineOptions& engine_options = in.engine_options;
  const std::vector<FrameRecord>& records = in.records;
  const std::map<size_t, ImageU8>& eval_masks = in.eval_masks;
  const GaussianCloud& cloud = in.cloud;
  const kernels::RasterSettings& raster = in.raster;
  const long total = in.total;
  const auto run_start = in.run_start;
  PipelineResult& result = *out;

  // Means of the timings.
  StageTimings& m = result.timings;
  for (const FrameRecord& r : records) {
    m.read_ms += r.t.read_ms;
    m.render_ms += r.t.render_ms;
    m.mask_ms += r.t.mask_ms;
    m.semantic_ms += r.t.semantic_ms;
    m.flow_ms += r.t.flow_ms;
    m.epipolar_ms += r.t.epipolar_ms;
    m.background_ms += r.t.background_ms;
    m.track_ms += r.t.track_ms;
    m.push_ms += r.t.push_ms;
    m.frame_ms += r.t.frame_ms;
    m.disparity_ms += r.t.disparity_ms;
    result.mean_mask_fraction += r.mask_fraction;
  }
  const double n = std::max<double>(1.0, records.size());
  for (double* v : {&m.read_ms, &m.render_ms, &m.mask_ms, &m.semantic_ms, &m.flow_ms, &m.epipolar_ms,
                    &m.background_ms, &m.track_ms, &m.push_ms, &m.frame_ms, &m.disparity_ms,
                    &result.mean_mask_fraction})
    *v /= n;

  // Trajectory accuracy.
  std::optional<TrajectoryEvaluation> evaluation;
  if (dataset.has_ground_truth() && result.trajectory.size() >= 2) {
    try {
      evaluation = EvaluateTrajectory(dataset.ground_truth(), result.trajectory, AteOptions(), RpeOptions());
      result.has_ate = true;
      result.ate_rmse = evaluation->ate.translation.rmse;
      if (evaluation->rpe) {
        result.has_rpe = true;
        result.rpe_translation_rmse = evaluation->rpe->translation.rmse;
        result.rpe_rotation_rmse = evaluation->rpe->rotation.rmse;
      }
      if (!result.map_trajectory.empty())
        result.map_ate_rmse = ComputeAte(dataset.ground_truth(), result.map_trajectory, AteOptions()).translation.rmse;
    } catch (const InvalidInput& e) {
      DYPHO_LOG(Warning) << "ATE not computed: " << e.message();
    }
  }

  // The independent map score (engine/eval/map_score.h) at every
  // eval_every-th frame, at the run's poses: the dataset's masks or, where
  // it has none, the run's own final masks leave moving things out.
  const Undistorter undistort(camera);
  MapScore map_score;
  std::vector<double> keyframe_times;
  if (fs::exists(fs::path(out_dir) / "keyframes.txt"))
    keyframe_times = ReadTumTrajectory((fs::path(out_dir) / "keyframes.txt").string()).timestamps;
  if (cloud.size() > 0 && options.eval_every > 0) {
    Trajectory posed;
    for (const FrameRecord& r : records) {
      if (r.has_pose) posed.Add(r.timestamp, r.cam_from_world.Inverse());
    }
    MapScoreOptions so;
    so.every = options.eval_every;
    so.first_frame = static_cast<size_t>(options.first_frame);
    so.max_frames = static_cast<size_t>(total);
    so.max_gap = 0.05;
    so.background = options.mapper.background;
    so.num_threads = options.mapper.num_threads;
    so.eval_downscale = options.eval_downscale;
    so.min_depth = options.mapper.min_depth;  // the depths the map was built from
    so.max_depth = options.mapper.max_depth;
    so.trained_timestamps = keyframe_times;
    so.fallback_masks = eval_masks;
    if (engine_options.mapper.sensor.active()) so.sensor = engine_options.mapper.sensor;
    try {
      map_score = ScoreMap(cloud, dataset, posed, so);
      WriteTextAtomically((fs::path(out_dir) / "scores.csv").string(), FormatMapScoreCsv(map_score));
    } catch (const InvalidInput& e) {
      DYPHO_LOG(Warning) << "the map was not scored: " << e.message();
    }
  }
  result.psnr = map_score.all.psnr;
  result.ssim = map_score.all.ssim;
  result.depth_l1 = map_score.all.depth_l1;
  result.scored_frames = map_score.all.frames;
  result.psnr_novel = map_score.untrained.frames > 0 ? map_score.untrained.psnr : std::nan("");
  result.psnr_aligned = map_score.all.psnr_aligned;
  result.psnr_sensor = map_score.all.psnr_sensor;
  result.worst_psnr = map_score.all.worst_psnr;
  result.coverage = map_score.all.coverage;

  // Keyframe renders beside the real images.
  std::vector<FramePair> pairs;
  const std::string renders_dir = (fs::path(out_dir) / "renders").string();
  std::vector<const FrameRecord*> keyframe_records;
  for (const FrameRecord& r : records) {
    for (double t : keyframe_times) {
      if (r.has_pose && std::abs(r.timestamp - t) < 1e-3) keyframe_records.push_back(&r);
    }
  }
  if (options.keyframe_renders > 0 && !keyframe_records.empty() && cloud.size() > 0) {
    MakeDirectories(renders_dir);
    const int count = std::min<int>(options.keyframe_renders, keyframe_records.size());
    for (int i = 0; i < count; ++i) {
      const FrameRecord& r = *keyframe_records[i * keyframe_records.size() / count];
      const Frame frame = dataset.Load(r.index);
      const RenderedView view = RenderView(cloud, undistort.pinhole(), r.cam_from_world, raster);
      FramePair pair;
      pair.rendered = ColorToU8(view.color);
      pair.real = undistort.Rgb(frame.rgb);
      char caption[96];
      std::snprintf(caption, sizeof(caption), "frame %zu (t = %.3f s)", r.index, r.timestamp);
      pair.caption = caption;
      char name[64];
      std::snprintf(name, sizeof(name), "kf_%06zu.png", r.index);
      WritePlot((fs::path(renders_dir) / name).string(), DrawFrameGrid({pair}));
      pairs.push_back(std::move(pair));
    }
    FrameGridOptions grid;
    grid.cell_width = std::min(320, camera.width);
    WritePlot((fs::path(out_dir) / "renders.png").string(), DrawFrameGrid(pairs, grid));
  }

  // Plots.
  std::vector<double> xs, frame_ms, mask_ms, track_ms, render_ms, backlog;
  for (const FrameRecord& r : records) {
    xs.push_back(static_cast<double>(xs.size()));
    frame_ms.push_back(r.t.frame_ms);
    mask_ms.push_back(r.t.mask_ms);
    track_ms.push_back(r.t.track_ms);
    render_ms.push_back(r.t.render_ms);
    backlog.push_back(r.backlog);
  }
  PlotOptions plot;
  plot.title = "per-frame time on the tracking thread";
  WritePlot((fs::path(out_dir) / "timings.png").string(),
            DrawLinePlot({{"frame", xs, frame_ms, {0, 0, 0}},
                          {"masks", xs, mask_ms, {200, 40, 40}},
                          {"tracker", xs, track_ms, {40, 90, 200}},
                          {"map render", xs, render_ms, {40, 160, 60}}},
                         "frame", "time [ms]", plot));
  plot.title = "keyframes waiting for the mapping thread";
  WritePlot((fs::path(out_dir) / "backlog.png").string(),
            DrawLinePlot({{"mapping backlog", xs, backlog, {120, 60, 160}}}, "frame", "keyframes", plot));
  if (evaluation) {
    PlotOptions top;
    top.plane = "auto";
    WritePlot((fs::path(out_dir) / "trajectory_top.png").string(),
              DrawTrajectoryTopView(dataset.ground_truth(), result.trajectory, evaluation->ate, top));
    WritePlot((fs::path(out_dir) / "error_over_time.png").string(),
              DrawErrorOverTime(evaluation->ate, evaluation->rpe ? &*evaluation->rpe : nullptr));
  }
  result.peak_rss_bytes = PeakRssBytes();
  result.total_seconds = std::chrono::duration<double>(Clock::now() - run_start).count();

  // Report.
  MarkdownReport report("dypho run: " + dataset.name());
  std::ostringstream intro;
  intro << "Dataset `" << dataset.folder() << "` (" << dataset.format() << ", " << camera.width << "x"
        << camera.height << "), preset `" << options.preset << "`, poses `" << options.poses << "`, "
        << result.mode << ". Frames processed " << result.frames
        << " of " << total << (result.interrupted ? " (**interrupted**)" : "") << "; with a pose " << result.tracked
        << ", without " << result.lost << "."
        << (result.unreadable_frames.empty()
                ? std::string()
                : " Unreadable frames skipped: " + std::to_string(result.unreadable_frames.size()) + ".")
        << (result.stopped_at.empty() ? std::string()
                                      : " Stopped at an unreadable frame (strict): " + result.stopped_at);
  report.AddParagraph(intro.str());
  std::vector<std::string> stages;
  stages.push_back(std::string("semantic ") +
                   (masking.segmenter.kind != "none" ? "on" : options.semantic ? "off (no --model given)" : "off"));
  stages.push_back(std::string("flow ") + (masking.use_flow ? "on" : "off"));
  stages.push_back(std::string("epipolar ") + (masking.use_epipolar ? "on" : "off"));
  stages.push_back(std::string("refinement ") + (masking.use_background ? "on" : "off"));
  stages.push_back(std::string("adaptive features ") + (tracker_options.extractor.adaptive_threshold ? "on" : "off"));
  stages.push_back(std::string("water/sky ") + (masking.use_shore ? "on" : "off"));
  std::string stage_text;
  for (const auto& s : stages) stage_text += (stage_text.empty() ? "" : ", ") + s;
  report.AddParagraph("Stages: " + stage_text + ". All options: `options.yaml`.");
  report.AddHeading("Results");
  std::vector<std::vector<std::string>> rows;
  if (result.has_ate) rows.push_back({"ATE RMSE", Fmt(100 * result.ate_rmse, 2) + " cm"});
  if (result.has_ate && !result.map_trajectory.empty())
    rows.push_back({"ATE RMSE of trajectory_map.txt (the frames moved with the refined keyframes)",
                    Fmt(100 * result.map_ate_rmse, 2) + " cm"});
  if (result.has_rpe) {
    rows.push_back({"RPE translation RMSE (1 s)", Fmt(100 * result.rpe_translation_rmse, 2) + " cm"});
    rows.push_back({"RPE rotation RMSE (1 s)", Fmt(result.rpe_rotation_rmse, 2) + " deg"});
  }
  if (!dataset.has_ground_truth()) rows.push_back({"ATE", "no ground truth"});
  rows.push_back({"map score: PSNR of the plain render at every " + std::to_string(options.eval_every) +
                      "th frame (" + std::to_string(result.scored_frames) + " frames; table below)",
                  Fmt(result.psnr, 2) + " dB"});
  rows.push_back({"SSIM / depth L1 / coverage", Fmt(result.ssim, 3) + " / " + Fmt(100 * result.depth_l1, 2) +
                                                     " cm / " + Fmt(100 * result.coverage, 1) + " %"});
  rows.push_back({"Gaussians", std::to_string(result.num_gaussians)});
  rows.push_back({"Dense map (dense.ply)", std::to_string(result.dense_voxels) + " voxels from " +
                                               std::to_string(result.dense_keyframes) + " keyframes, " +
                                               FormatFixed(result.dense_mb, 1) + " MB, " +
                                               FormatFixed(result.dense_ms_mean, 2) + " ms per keyframe (max " +
                                               FormatFixed(result.dense_ms_max, 2) + ")"});
  rows.push_back({"keyframes taken / mapped / mapped late (of them spilled to disk) / dropped",
                  std::to_string(result.keyframes) + " / " + std::to_string(result.mapped_keyframes) + " / " +
                      std::to_string(result.late_keyframes) + " (" + std::to_string(result.spilled_keyframes) +
                      ") / 0"});
  if (result.push_waits > 0)
    rows.push_back({"frames that waited for room for a keyframe (memory bound, no spill folder)",
                    std::to_string(result.push_waits)});
  rows.push_back({"tracking rate (frames / frame-loop wall time)", Fmt(result.tracking_fps, 1) + " frames/s"});
  if (masking.segmenter.kind != "none")
    rows.push_back({"detector results used (mean / largest age of the semantic mask)",
                    std::to_string(result.detector_results) + " (" + Fmt(result.semantic_age_mean, 1) + " / " +
                        std::to_string(result.semantic_age_max) + " frames)"});
  if (masking.segmenter.kind != "none")
    rows.push_back({"detector runs on keyframes with a carried mask (keyframe_detection; mean time, on the mapping "
                    "thread / runs on the tracking thread)",
                    std::to_string(result.keyframe_detections) + " (" + Fmt(result.keyframe_detection_ms, 1) +
                        " ms / " + std::to_string(result.keyframe_detections_on_push) + "); refined by the "
                        "frame's background: " + std::to_string(result.keyframe_detections_refined) + ", " +
                        Fmt(100.0 * result.keyframe_detection_static, 1) + " % of their pixels made static"});
  if (options.background_prior == "frames")
    rows.push_back({"background priors from earlier frames (mean time on the tracking thread)",
                    std::to_string(result.map_renders_used) + " (" + Fmt(result.map_render_ms, 1) + " ms)"});
  else
    rows.push_back({"map renders for the background (mean time on their thread, mean age when used)",
                    std::to_string(result.map_renders_used) + " (" + Fmt(result.map_render_ms, 1) + " ms, " +
                        Fmt(result.map_render_lag, 1) + " frames)"});
  if (result.mask_lag > 0 || result.mask_look_ahead > 0 || (!options.sequential && options.max_render_age > 0))
    rows.push_back({"fixed ages: detector waits (frames, time) / time waiting for map renders",
                    std::to_string(result.detector_waits) + ", " + Fmt(result.detector_wait_ms, 0) + " ms / " +
                        Fmt(result.render_wait_ms, 0) + " ms"});
  if (options.realtime)
    rows.push_back({"realtime replay: frames dropped (a newer frame had arrived)",
                    std::to_string(result.dropped_frames) + " of " + std::to_string(total)});
  rows.push_back({"largest mapping backlog", std::to_string(result.max_backlog) + " keyframes"});
  rows.push_back({"mapping after the last frame", Fmt(result.finish_seconds, 1) + " s (final refinement " +
                                                    std::to_string(result.final_iterations) + " steps, stopped: " +
                                                    (result.final_stop.empty() ? "-" : result.final_stop) + ")"});
  rows.push_back({"Gaussians removed as seen through by other keyframes", std::to_string(result.carved_gaussians)});
  if (options.mapper.refine_poses) {
    const FollowStats& f = result.keyframe_follow;
    rows.push_back({"keyframe poses refined against the map (mapper.refine_poses; the other frames follow them in trajectory_map.txt)",
                    std::to_string(f.keyframes) + " keyframes moved by " + Fmt(f.mean_translation * 1000, 1) +
                        " mm, " + Fmt(f.mean_rotation_deg, 2) + " deg on average (at most " +
                        Fmt(f.max_translation * 1000, 1) + " mm, " + Fmt(f.max_rotation_deg, 2) + " deg)"});
  }
  if (options.poses == "orb") {
    std::string loops = std::to_string(result.loops.size());
    for (const LoopResponseRecord& l : result.loops)
      loops += "; frame " + std::to_string(l.frame) + " with frame " + std::to_string(l.matched_frame) + ", " +
               std::to_string(l.inliers) + " inliers, correction " + Fmt(l.correction_cm, 1) + " cm " +
               Fmt(l.correction_deg, 2) + " deg, " + std::to_string(l.keyframes_moved) + " keyframes moved, " +
               std::to_string(l.refine_steps) + " refinement steps";
    rows.push_back({"loops closed", options.tracker.loops.enabled ? loops : "off (--disable loops)"});
  }
  rows.push_back({"frame loop / whole run", Fmt(result.loop_seconds, 1) + " s / " + Fmt(result.total_seconds, 1) +
                                                " s"});
  if (!result.thread_cpu.empty()) {
    std::string cpu;
    double total = 0.0;
    for (const ThreadCpuUse& u : result.thread_cpu) {
      if (u.cores < 0.005) continue;
      cpu += (cpu.empty() ? "" : ", ") + u.name + " " + Fmt(u.cores, 2);
      total += u.cores;
    }
    rows.push_back({"CPU during the frame loop, by thread [cores]", cpu + " (total " + Fmt(total, 2) + ")"});
  }
  rows.push_back({"mean dynamic fraction of a frame", Fmt(100 * result.mean_mask_fraction, 1) + " %"});
  rows.push_back({"peak memory (RSS)", Fmt(result.peak_rss_bytes / 1048576.0, 0) + " MiB"});
  report.AddTable({"quantity", "value"}, rows);
  if (map_score.all.frames > 0) {
    report.AddHeading("Map score");
    std::string text =
        "The exported map rendered at the run's pose of every " + std::to_string(options.eval_every) +
        "th frame and compared with the real frame, undistorted, over the whole image but the undistortion border " +
        "and the dynamic masks (the dataset's, else the run's own). `PSNR aligned`: after a per-frame affine colour "
        "fit (removes automatic exposure), reported apart. `dypho score` computes the same table for any map. Per "
        "frame: `scores.csv`.";
    if (std::isfinite(result.psnr_sensor))
      text += " `PSNR sensor model`: the render through the camera's rolling shutter and motion blur.";
    report.AddParagraph(text);
    report.AddParagraph(FormatMapScoreTable(map_score));
  }
  report.AddHeading("Per-stage timings (mean per frame, tracking thread)");
  report.AddTable({"stage", "ms"}, {{"read (wait)", Fmt(m.read_ms, 2)},
                                    {"map depth (render requests, warp to the predicted pose)", Fmt(m.render_ms, 2)},
                                    {"masks (total)", Fmt(m.mask_ms, 2)},
                                    {"- semantic", Fmt(m.semantic_ms, 2)},
                                    {"- flow motion", Fmt(m.flow_ms, 2)},
                                    {"- epipolar check", Fmt(m.epipolar_ms, 2)},
                                    {"- background refinement", Fmt(m.background_ms, 2)},
                                    {"tracker", Fmt(m.track_ms, 2)},
                                    {"engine push" + std::string(options.sequential ? " (incl. mapping)" : ""),
                                     Fmt(m.push_ms, 2)},
                                    {"whole frame", Fmt(m.frame_ms, 2)}});
  if (result.frame_disparities > 0) {
    report.AddParagraph(
        "Stereo disparity: " + std::to_string(result.frame_disparities) + " in the frame loader (reader thread, " +
        (result.frame_disparity_downscale > 1 ? "previews at 1/" + std::to_string(result.frame_disparity_downscale) +
                                                    " resolution"
                                              : std::string("full resolution")) +
        ", " + Fmt(m.disparity_ms, 2) + " ms a frame); " + std::to_string(result.keyframe_disparities) +
        " full ones for keyframes in the engine (" + Fmt(result.keyframe_disparity_ms, 2) + " ms each).");
  }
  report.AddImage("timings.png", "per-frame timings");
  report.AddImage("backlog.png", "mapping backlog");
  if (evaluation) {
    report.AddHeading("Trajectory");
    report.AddImage("trajectory_top.png", "trajectory, top view");
    report.AddImage("error_over_time.png", "error over time");
  }
  if (!pairs.empty()) {
    report.AddHeading("Keyframe renders (left) beside the real images (right)");
    report.AddImage("renders.png", "keyframe renders");
  }
  report.AddParagraph("Outputs: `trajectory.txt` (the tracker's poses), " +
                      std::string(result.map_trajectory.empty()
                                      ? ""
                                      : "`trajectory_map.txt` (the poses in the refined map: render and score "
                                        "the map at these), ") +
                      "`keyframes.txt` (TUM format), `map.ply`" +
                      std::string(options.write_splat ? ", `map.splat`" : "") +
                      (options.write_glb ? ", `map.glb`" : "") + (options.write_spz ? ", `map.spz`" : "") +
                      ", `renders/`, `overlays/`, `metrics.json`.");
  result.report_path = (fs::path(out_dir) / "report.md").string();
  report.Write(result.report_path);

  nlohmann::json j;
  j["dataset"] = result.dataset;
  j["frames"] = result.frames;
  j["tracked"] = result.tracked;
  j["lost"] = result.lost;
  j["interrupted"] = result.interrupted;
  j["unreadable_frames"] = result.unreadable_frames;
  if (!result.stopped_at.empty()) j["stopped_at"] = result.stopped_at;
  if (result.has_ate) j["ate_rmse_m"] = result.ate_rmse;
  if (result.has_ate && !result.map_trajectory.empty()) j["map_trajectory_ate_rmse_m"] = result.map_ate_rmse;
  if (result.has_rpe) {
    j["rpe_translation_rmse_m"] = result.rpe_translation_rmse;
    j["rpe_rotation_rmse_deg"] = result.rpe_rotation_rmse;
  }
  j["psnr_db"] = result.psnr;
  j["psnr_novel_db"] = result.psnr_novel;
  j["psnr_aligned_db"] = result.psnr_aligned;
  j["psnr_sensor_db"] = result.psnr_sensor;
  j["worst_psnr_db"] = result.worst_psnr;
  j["coverage"] = result.coverage;
  j["carved_gaussians"] = result.carved_gaussians;
  if (result.keyframe_follow.keyframes > 0) {
    const FollowStats& f = result.keyframe_follow;
    j["keyframe_refinement"] = {{"keyframes", f.keyframes},
                                {"mean_translation_m", f.mean_translation},
                                {"max_translation_m", f.max_translation},
                                {"mean_rotation_deg", f.mean_rotation_deg},
                                {"max_rotation_deg", f.max_rotation_deg}};
  }
  j["ssim"] = result.ssim;
  j["depth_l1_m"] = result.depth_l1;
  j["scored_frames"] = result.scored_frames;
  j["keyframes"] = result.keyframes;
  j["mapped_keyframes"] = result.mapped_keyframes;
  j["late_keyframes"] = result.late_keyframes;
  j["spilled_keyframes"] = result.spilled_keyframes;
  j["push_waits"] = result.push_waits;
  j["final_stop"] = result.final_stop;
  j["shortened_keyframes"] = result.shortened_keyframes;
  j["max_backlog"] = result.max_backlog;
  j["gaussians"] = result.num_gaussians;
  nlohmann::json loops = nlohmann::json::array();
  for (const LoopResponseRecord& l : result.loops)
    loops.push_back({{"frame", l.frame}, {"matched_frame", l.matched_frame}, {"inliers", l.inliers},
                     {"correction_cm", l.correction_cm}, {"correction_deg", l.correction_deg},
                     {"frames_corrected", l.frames_corrected}, {"keyframes_moved", l.keyframes_moved},
                     {"keyframes_skipped", l.keyframes_skipped}, {"refine_steps", l.refine_steps}});
  j["loops"] = loops;
  j["dense"] = {{"keyframes", result.dense_keyframes}, {"voxels", result.dense_voxels}, {"mb", result.dense_mb},
                {"ms_per_keyframe", result.dense_ms_mean}, {"ms_max", result.dense_ms_max}};
  j["tracking_fps"] = result.tracking_fps;
  j["map_renders_used"] = result.map_renders_used;
  j["detector_results"] = result.detector_results;
  j["keyframe_detections"] = result.keyframe_detections;
  j["keyframe_detection_ms"] = result.keyframe_detection_ms;
  j["keyframe_detections_on_push"] = result.keyframe_detections_on_push;
  j["keyframe_detections_refined"] = result.keyframe_detections_refined;
  j["keyframe_detection_static_fraction"] = result.keyframe_detection_static;
  j["semantic_age_mean_frames"] = result.semantic_age_mean;
  j["semantic_age_max_frames"] = result.semantic_age_max;
  j["map_render_ms"] = result.map_render_ms;
  j["map_render_lag_frames"] = result.map_render_lag;
  j["mode"] = result.mode;
  j["sequential"] = options.sequential;
  j["max_mask_age"] = options.max_mask_age;
  j["mask_look_ahead"] = result.mask_look_ahead;
  j["mask_lag_frames"] = result.mask_lag;
  j["max_render_age"] = options.max_render_age;
  j["detector_waits"] = result.detector_waits;
  j["detector_wait_ms"] = result.detector_wait_ms;
  j["render_wait_ms"] = result.render_wait_ms;
  j["realtime"] = options.realtime;
  j["realtime_speed"] = options.realtime_speed;
  j["dropped_frames"] = result.dropped_frames;
  j["loop_seconds"] = result.loop_seconds;
  for (const ThreadCpuUse& u : result.thread_cpu) j["thread_cpu_cores"][u.name] = u.cores;
  j["finish_seconds"] = result.finish_seconds;
  j["final_iterations"] = result.final_iterations;
  j["total_seconds"] = result.total_seconds;
  j["mean_mask_fraction"] = result.mean_mask_fraction;
  j["peak_rss_bytes"] = result.peak_rss_bytes;
  j["timings_ms"] = {{"read", m.read_ms},         {"render", m.render_ms},   {"mask", m.mask_ms},
                     {"semantic", m.semantic_ms}, {"flow", m.flow_ms},       {"epipolar", m.epipolar_ms},
                     {"background", m.background_ms}, {"track", m.track_ms}, {"push", m.push_ms},
                     {"frame", m.frame_ms}, {"disparity", m.disparity_ms}};
  j["frame_disparities"] = result.frame_disparities;
  j["frame_disparity_downscale"] = result.frame_disparity_downscale;
  j["keyframe_disparities"] = result.keyframe_disparities;
  j["keyframe_disparity_ms"] = result.keyframe_disparity_ms;
  WriteTextAtomically((fs::path(out_dir) / "metrics.json").string(), j.dump(2) + "\n");
}


}  // namespace dypho
