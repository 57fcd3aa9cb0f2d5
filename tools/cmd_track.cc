// `dypho track`: runs the ORB tracker over an RGB-D dataset and writes the
// trajectory (TUM format, one pose per frame).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <cstdio>
#include <filesystem>
#include <future>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/check.h"
#include "common/files.h"
#include "common/logging.h"
#include "common/progress.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/ate.h"
#include "engine/eval/trajectory.h"
#include "tools/command.h"
#include "tools/option_sets.h"
#include "tracker/anchored_trajectory.h"
#include "tracker/cv_view.h"
#include "tracker/orb_tracker.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

namespace fs = std::filesystem;

// Rolling-shutter readout of the Kinect v1 RGB camera (TUM RGB-D): the value
// that minimises the ATE on tum_fr1_rpy_head250 (0.020..0.030 s all give
// 1.2..1.7 cm; without the model 3.5..4.7 cm).
constexpr double kKinectV1Readout = 0.025;

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1) + 0.5));
  return values[k];
}

int RunTrack(int argc, char** argv) {
  CLI::App app{
      "Track an RGB-D dataset (TUM/Bonn layout or a generic folder with camera.yaml) with the ORB tracker and "
      "write its trajectory in the TUM format ('timestamp tx ty tz qx qy qz qw', world_from_cam, the world "
      "being the first tracked camera), one line per frame: frames that are lost or not yet initialised repeat "
      "the last pose. Prints the ATE when the dataset has ground truth.",
      "dypho track"};
  std::string folder, out_path, masks_dir;
  bool write_into_dataset = false;
  bool no_adaptive = false;
  int threads = DefaultThreadCount();
  long max_frames = 0;
  bool verbose = false;
  std::string rolling_shutter = "auto";
  bool sequential = false, raw_poses = false;
  std::string vocabulary;
  std::vector<std::string> disable;
  app.add_option("dataset", folder, "dataset folder")->required();
  app.add_flag("--write-into-dataset", write_into_dataset,
               "allow the output inside the input dataset folder (refused otherwise: it could overwrite its files)");
  app.add_option("--out", out_path, "trajectory file to write (TUM format)")->required()->check(NonEmptyPath());
  app.add_option("--masks", masks_dir,
                 "folder of 8-bit dynamic masks named like the RGB images (255 = dynamic; values in between "
                 "are soft: static weight = 1 - value/255, features where value >= 128 are dropped)");
  app.add_flag("--no-adaptive", no_adaptive, "keep the FAST thresholds fixed where the mask removes support");
  app.add_option("--threads", threads, "threads (OpenCV, pyramid levels, reading the next frame)")
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxThreads));
  app.add_option("--frames", max_frames, "track only the first N frames (0 = all)")->check(CLI::NonNegativeNumber);
  app.add_option("--rolling-shutter", rolling_shutter,
                 "rolling-shutter readout time of the RGB camera [s] (first to last row), 0 for a global shutter; "
                 "auto = 0.025 for TUM RGB-D folders (Kinect v1, estimated on fr1/rpy), else 0")
      ->capture_default_str();
  app.add_flag("--sequential", sequential,
               "run the back end (local BA, loop detection and closure) on the tracking thread: identical results run to run");
  app.add_option("--vocabulary", vocabulary,
                 "bag-of-words vocabulary for relocalisation (`dypho vocab train`); default: trained at start-up "
                 "from the first 5 keyframes");
  app.add_flag("--raw-poses", raw_poses,
               "write each frame's pose as tracked; by default a frame moves with its reference keyframe as the "
               "local BA refines it afterwards");
  app.add_option("--disable", disable, "switch a back-end part off: local-ba|loops (repeatable)")
      ->check(CLI::IsMember({"local-ba", "loops"}));
  app.add_flag("-v,--verbose", verbose, "log every frame (status, matches, inliers, keyframes, time)");
  std::vector<std::string> sets;
  app.add_option("--set", sets,
                 "override one tracker option: tracker.KEY=VALUE (repeatable; the keys of `dypho run "
                 "--print-config`), e.g. --set tracker.keyframe_max_frames=10; applied after the flags");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  cv::setNumThreads(threads);
  if (verbose) SetLogLevel(LogLevel::kDebug);

  CheckOutsideDataset(out_path, folder, "--out", write_into_dataset);
  const std::unique_ptr<Dataset> dataset = OpenDataset(folder);
  const size_t n = max_frames > 0 ? std::min(dataset->size(), static_cast<size_t>(max_frames)) : dataset->size();
  DYPHO_CHECK_INPUT(n > 0) << "dataset " << folder << " has no frames";
  std::vector<std::string> mask_paths;
  if (!masks_dir.empty()) {
    DYPHO_CHECK_INPUT(fs::is_directory(masks_dir)) << "--masks " << masks_dir << " is not a folder";
    for (size_t i = 0; i < n; ++i) {
      const std::string path = (fs::path(masks_dir) / fs::path(dataset->info(i).rgb_path).filename()).string();
      DYPHO_CHECK_INPUT(fs::exists(path)) << "mask " << path << " for frame " << i << " ("
                                          << dataset->info(i).rgb_path << ") does not exist";
      mask_paths.push_back(path);
    }
  }

  OrbTrackerOptions options;
  options.extractor.adaptive_threshold = !no_adaptive;
  if (rolling_shutter == "auto") {
    options.rolling_shutter_readout = dataset->format() == "tum" ? kKinectV1Readout : 0.0;
  } else {
    char* end = nullptr;
    const double value = std::strtod(rolling_shutter.c_str(), &end);
    DYPHO_CHECK_INPUT(!rolling_shutter.empty() && *end == '\0' && std::isfinite(value))
        << "--rolling-shutter must be a time in seconds or 'auto' (got '" << rolling_shutter << "')";
    options.rolling_shutter_readout = value;
  }
  options.local_ba.threaded = !sequential;
  options.loops.threaded = !sequential;
  // As in dypho run: the back end's results reach the live map a fixed number
  // of frames after their keyframe (the tracker waits for a late one), so a
  // busy machine gives the same trajectory later, not another one (a closure
  // that landed 34 frames late under load made the ATE worse than no loops).
  options.local_ba.fixed_lag = 1;
  options.loops.fixed_lag = 2;
  options.vocabulary_path = vocabulary;
  for (const std::string& d : disable) {
    if (d == "local-ba") options.local_ba.enabled = false;
    if (d == "loops") options.loops.enabled = false;
  }
  ApplyPartSets(sets, "tracker.", &PipelineOptions::tracker, &options, "dypho track");
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  OrbTracker tracker(dataset->camera(), options);
  Trajectory estimate;
  AnchoredTrajectory anchored;  // re-anchored on the back end's keyframe poses at the end
  std::vector<double> frame_ms, extract_ms, track_ms, map_ms;
  std::array<std::vector<double>, 8> stage_ms;  // ORB extraction stages, as printed below
  int counts[4] = {0, 0, 0, 0};
  int keyframes = 0;
  Progress progress("track", static_cast<long>(n));
  auto load = [&](size_t i) { return dataset->Load(i); };
  std::future<Frame> next;
  if (threads > 1) next = std::async(std::launch::async, load, 0);
  for (size_t i = 0; i < n; ++i) {
    Frame frame = threads > 1 ? next.get() : load(i);
    if (threads > 1 && i + 1 < n) next = std::async(std::launch::async, load, i + 1);
    TrackerFrame input;
    input.timestamp = frame.timestamp;
    input.image = CvView(frame.rgb);
    if (frame.has_depth) input.depth = CvView(frame.depth);
    cv::Mat mask, weight;
    if (!mask_paths.empty()) {
      const cv::Mat raw = cv::imread(mask_paths[i], cv::IMREAD_GRAYSCALE);
      DYPHO_CHECK_INPUT(!raw.empty()) << "cannot read mask " << mask_paths[i];
      DYPHO_CHECK_INPUT(raw.cols == input.image.cols && raw.rows == input.image.rows)
          << "mask " << mask_paths[i] << " is " << raw.cols << "x" << raw.rows << " but the RGB image is "
          << input.image.cols << "x" << input.image.rows;
      cv::compare(raw, 128, mask, cv::CMP_GE);
      raw.convertTo(weight, CV_32F, -1.0 / 255.0, 1.0);
      input.dynamic_mask = mask;
      input.static_weight = weight;
    }
    const TrackResult result = tracker.Track(input);
    ++counts[static_cast<int>(result.status)];
    keyframes += result.is_keyframe;
    frame_ms.push_back(result.timing.total_ms);
    extract_ms.push_back(result.timing.extract_ms);
    track_ms.push_back(result.timing.track_ms);
    map_ms.push_back(result.timing.map_ms);
    const OrbStageTimes& st = tracker.last_extraction_stats().times;
    const double stage_values[] = {st.pyramid_ms,     st.masks_ms,   st.fast_ms,       st.grid_ms,
                                   st.orientation_ms, st.blur_ms,    st.descriptor_ms, st.gather_ms};
    for (size_t k = 0; k < stage_ms.size(); ++k) stage_ms[k].push_back(stage_values[k]);
    estimate.Add(frame.timestamp, result.cam_from_world.Inverse());
    anchored.Add(result, tracker);
    DYPHO_LOG(Debug) << "frame " << i << " t=" << std::to_string(frame.timestamp) << " "
                     << TrackStatusName(result.status) << " features " << result.features.size() << " from "
                     << CoarseSourceName(result.coarse_source) << " (" << result.coarse_matches << " matches) matches "
                     << result.num_matches << " inliers " << result.num_inliers
                     << (result.is_keyframe ? " keyframe" : "") << " " << result.timing.total_ms << " ms"
                     << (result.message.empty() ? "" : " (" + result.message + ")");
    progress.Advance(1, std::string(TrackStatusName(result.status)) + ", " + std::to_string(result.num_inliers) +
                            " inliers");
  }
  progress.Finish();
  tracker.FlushBackend();
  if ((options.local_ba.enabled || options.loops.enabled) && !raw_poses) {
    // Each frame moves with its reference keyframe (as the back end refined
    // it, local BA and loop closure): cam_from_world = cam_from_keyframe *
    // keyframe_from_world.
    const std::vector<Rigid3d> poses = anchored.CamFromWorld(tracker);
    for (size_t i = 0; i < estimate.size(); ++i) estimate.world_from_cam[i] = poses[i].Inverse();
  }
  WriteTumTrajectory(out_path, estimate);

  std::printf("frames %zu: ok %d, relocalized %d, lost %d, initializing %d; keyframes %d, map points %d\n", n,
              counts[static_cast<int>(TrackStatus::kOk)], counts[static_cast<int>(TrackStatus::kRelocalized)],
              counts[static_cast<int>(TrackStatus::kLost)], counts[static_cast<int>(TrackStatus::kInitializing)],
              keyframes, tracker.num_map_points());
  const OrbBackendStats& backend = tracker.backend_stats();
  if (options.local_ba.enabled) {
    std::printf("local BA: %d runs (%d keyframes without one), %.1f ms mean, %.1f ms max (%s); %ld outlier "
                "observations erased; %d keyframes culled, %d live\n",
                backend.local_ba_runs, backend.local_ba_skipped,
                backend.local_ba_runs > 0 ? backend.local_ba_ms / backend.local_ba_runs : 0.0, backend.local_ba_max_ms,
                sequential ? "sequential" : "threaded", backend.erased_observations, backend.culled_keyframes,
                tracker.num_live_keyframes());
  } else {
    std::printf("local BA: off\n");
  }
  if (options.loops.enabled) {
    std::printf("loops (%s): %zu closed; %d queries, %.2f ms mean, %.2f ms max; pose graph %.1f ms, global BA "
                "%.0f ms in all\n",
                sequential ? "sequential" : "threaded", backend.loops.size(), backend.loop_queries,
                backend.loop_queries > 0 ? backend.loop_query_ms / backend.loop_queries : 0.0,
                backend.loop_query_max_ms, backend.pose_graph_ms, backend.global_ba_ms);
    if (!sequential)
      std::printf("  map snapshots for the loop thread (tracking thread): %.2f ms mean, %.2f ms max\n",
                  backend.loop_queries > 0 ? backend.loop_snapshot_ms / backend.loop_queries : 0.0,
                  backend.loop_snapshot_max_ms);
    for (const LoopRecord& l : backend.loops)
      std::printf("  loop t=%.3f: keyframe %d with keyframe %d, %d inliers, %d points fused, correction %.2f cm "
                  "%.2f deg, graph %.1f ms, applied %ld frames after its keyframe\n",
                  l.timestamp, l.keyframe, l.matched, l.inliers, l.fused, 100.0 * l.translation, l.rotation_deg,
                  l.pose_graph_ms, l.applied_frames_later);
  } else {
    std::printf("loops: off\n");
  }
  std::printf("tracking time per frame: median %.2f ms, p95 %.2f ms (%d threads); medians: features %.2f ms, "
              "tracking %.2f ms, keyframes %.2f ms\n",
              Percentile(frame_ms, 0.5), Percentile(frame_ms, 0.95), threads, Percentile(extract_ms, 0.5),
              Percentile(track_ms, 0.5), Percentile(map_ms, 0.5));
  std::printf("ORB extraction stages, medians [ms] (per-level stages summed over the levels):");
  const char* stage_names[] = {"pyramid", "masks", "FAST", "grid", "orientation", "blur", "descriptors", "gather"};
  for (size_t k = 0; k < stage_ms.size(); ++k) std::printf(" %s %.2f", stage_names[k], Percentile(stage_ms[k], 0.5));
  std::printf("\n");
  std::printf("trajectory %s (rolling shutter %.3f s, adaptive threshold %s)\n", out_path.c_str(),
              options.rolling_shutter_readout, no_adaptive ? "off" : "on");
  if (dataset->has_ground_truth()) {
    try {
      const AteResult ate = ComputeAte(dataset->ground_truth(), estimate);
      std::printf("ATE RMSE %.4f m (mean %.4f, median %.4f, max %.4f; %zu poses matched)\n", ate.translation.rmse,
                  ate.translation.mean, ate.translation.median, ate.translation.max, ate.translation.count);
    } catch (const InvalidInput& e) {
      std::printf("ATE not computed: %s\n", e.message().c_str());
    }
  }
  return 0;
}

}  // namespace

DYPHO_COMMAND("track", "track an RGB-D dataset with the ORB tracker and write the trajectory (TUM format)",
              RunTrack);

}  // namespace dypho::tools
