// `dypho eval`: trajectory accuracy (ATE, RPE) as in the TUM RGB-D benchmark,
// optionally the KITTI odometry metric.
// `dypho dataset-info`: what a dataset folder holds.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "common/check.h"
#include "common/logging.h"
#include "engine/dataset/dataset.h"
#include "engine/dataset/dataset_info.h"
#include "engine/stereo/stereo_dataset.h"
#include "engine/eval/ate.h"
#include "engine/eval/kitti_error.h"
#include "engine/eval/plots.h"
#include "engine/eval/report.h"
#include "engine/eval/trajectory.h"
#include "tools/command.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

// The path lengths of `dypho eval --kitti`: "auto" or a comma list [m].
std::vector<double> KittiLengths(const std::string& text, const Trajectory& gt) {
  std::vector<double> lengths;
  if (text == "auto") {
    double path = 0.0;
    for (size_t i = 1; i < gt.size(); ++i)
      path += (gt.world_from_cam[i].translation - gt.world_from_cam[i - 1].translation).norm();
    for (double l = 100; l <= 800 && l <= path; l += 100) lengths.push_back(l);
    if (lengths.empty())
      for (double l = 10; l <= path; l += 10) lengths.push_back(l);
    DYPHO_CHECK_INPUT(!lengths.empty()) << "--kitti auto: the matched ground-truth path is only "
                                        << FormatFixed(path, 2) << " m (10 m at least)";
    return lengths;
  }
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    double l = 0.0;
    size_t used = 0;
    try {
      l = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    DYPHO_CHECK_INPUT(used == item.size() && std::isfinite(l) && l > 0)
        << "--kitti: '" << item << "' is not a positive length in metres (expected 'auto' or e.g. 10,20,40)";
    lengths.push_back(l);
  }
  DYPHO_CHECK_INPUT(!lengths.empty()) << "--kitti: no lengths given";
  return lengths;
}

int RunEval(int argc, char** argv) {
  CLI::App app{
      "Absolute trajectory error (ATE, after SE(3) or Sim(3) alignment) and relative pose error "
      "(RPE per delta seconds) of an estimated trajectory, as the TUM RGB-D benchmark's "
      "evaluate_ate.py and evaluate_rpe.py. Files: 'timestamp tx ty tz qx qy qz qw' per line.",
      "dypho eval"};
  std::string gt_path, est_path, plots_dir;
  AteOptions ate;
  RpeOptions rpe;
  app.add_option("--gt", gt_path,
                 "ground-truth trajectory (TUM format), or a dataset folder with ground truth (groundtruth.txt, "
                 "KITTI poses.txt, EuRoC state_groundtruth_estimate0)")
      ->required();
  app.add_option("--est", est_path, "estimated trajectory (TUM format)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_flag("--scale", ate.estimate_scale,
               "align with Sim(3) (estimate the scale, e.g. for monocular runs)");
  app.add_option("--max-dt", ate.max_time_difference, "largest timestamp difference for a match [s]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--offset", ate.time_offset, "time offset added to the estimated timestamps [s]")
      ->capture_default_str();
  app.add_option("--rpe-delta", rpe.delta, "time between the poses of an RPE pair [s]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--plots", plots_dir, "write trajectory_top.png, error_over_time.png and report.md here")
      ->check(NonEmptyPath());
  std::string kitti_lengths;
  app.add_option("--kitti", kitti_lengths,
                 "also the KITTI odometry metric (mean relative translation error in % and rotation in deg/m over "
                 "all sub-sequences of the given path lengths, on the unaligned poses): 'auto' (100, 200, .., 800 m, "
                 "or 10 m steps for a shorter ground-truth path) or lengths in metres, e.g. 10,20,40");
  std::string plane = "xy";
  app.add_option("--plot-plane", plane, "top-view axes: xy (z up, as TUM/Bonn), xz, yz or auto")
      ->capture_default_str()
      ->check(CLI::IsMember({"xy", "xz", "yz", "auto"}));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  rpe.time_offset = ate.time_offset;

  Trajectory ground_truth;
  if (std::filesystem::is_directory(gt_path) &&
      !std::filesystem::exists(std::filesystem::path(gt_path) / "groundtruth.txt")) {
    // A dataset folder whose reader knows its ground truth (KITTI poses.txt, EuRoC).
    const std::unique_ptr<Dataset> dataset = OpenDataset(gt_path);
    DYPHO_CHECK_INPUT(dataset->has_ground_truth()) << gt_path << ": the dataset has no ground truth";
    ground_truth = dataset->ground_truth();
  } else {
    if (std::filesystem::is_directory(gt_path))
      gt_path = (std::filesystem::path(gt_path) / "groundtruth.txt").string();
    ground_truth = ReadTumTrajectory(gt_path);
  }
  const Trajectory estimate = ReadTumTrajectory(est_path);
  for (const auto& [path, poses] : {std::pair<const std::string&, const Trajectory&>{gt_path, ground_truth},
                                    {est_path, estimate}}) {
    DYPHO_CHECK_INPUT(!poses.empty()) << path << " holds no poses (expected lines 'timestamp tx ty tz qx qy qz qw')";
  }
  TrajectoryEvaluation evaluation = EvaluateTrajectory(ground_truth, estimate, ate, rpe);
  evaluation.ground_truth_path = gt_path;
  evaluation.estimate_path = est_path;
  std::printf("%s", FormatEvaluation(evaluation).c_str());
  if (!kitti_lengths.empty()) {
    // The matched poses, in order (the metric pairs frame i of both).
    Trajectory gt_matched, est_matched;
    for (size_t k = 0; k < evaluation.ate.gt_indices.size(); ++k) {
      const size_t g = evaluation.ate.gt_indices[k], e = evaluation.ate.est_indices[k];
      gt_matched.Add(ground_truth.timestamps[g], ground_truth.world_from_cam[g]);
      est_matched.Add(estimate.timestamps[e], estimate.world_from_cam[e]);
    }
    const std::vector<double> lengths = KittiLengths(kitti_lengths, gt_matched);
    const KittiError kitti = ComputeKittiError(gt_matched, est_matched, lengths);
    std::string list;
    for (double l : lengths) list += (list.empty() ? "" : ",") + FormatFixed(l, 0);
    std::printf("kitti_lengths %s m\nkitti_segments %d\nkitti_translation_error %.3f %%\n"
                "kitti_rotation_error %.5f deg/m\n",
                list.c_str(), kitti.segments, kitti.translation_percent, kitti.rotation_deg_per_m);
  }
  if (!plots_dir.empty()) {
    PlotOptions plot_options;
    plot_options.plane = plane;
    const std::string report =
        WriteEvaluationReport(plots_dir, ground_truth, estimate, evaluation, plot_options);
    std::printf("report %s\n", report.c_str());
  }
  return 0;
}

int RunDatasetInfo(int argc, char** argv) {
  CLI::App app{
      "Describe an RGB-D dataset folder (TUM, Bonn or generic with camera.yaml/json): frames, camera, "
      "depth and ground-truth coverage. Decodes every frame unless --quick.",
      "dypho dataset-info"};
  std::string folder;
  DatasetOptions options;
  bool quick = false;
  app.add_option("dataset", folder, "dataset folder")->required();
  app.add_option("--camera-preset", options.camera_preset,
                 "freiburg1|freiburg2|freiburg3|bonn (default: auto)");
  app.add_option("--camera-file", options.camera_file, "YAML/JSON camera file (default: auto)");
  app.add_option("--depth-factor", options.depth_factor,
                 "depth units per metre (default: camera file or 5000)");
  AddDepthTimeOption(app, &options.depth_time);
  app.add_flag("--quick", quick, "only read the lists; do not decode the images");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  const std::unique_ptr<Dataset> dataset = OpenDataset(folder, options);
  if (quick) {
    std::printf("%s", DescribeDataset(*dataset).c_str());
  } else {
    const DatasetScan scan = ScanDataset(*dataset, /*show_progress=*/true);
    std::printf("%s", DescribeDataset(*dataset, &scan).c_str());
  }
  return 0;
}

int RunKittiToTum(int argc, char** argv) {
  CLI::App app{"Convert a KITTI odometry poses file (12 numbers a line: the row-major 3x4 world_from_cam0) to a "
               "TUM trajectory ('timestamp tx ty tz qx qy qz qw'), with the times of a KITTI times.txt "
               "(default: 10 Hz from 0).",
               "dypho kitti-to-tum"};
  std::string poses, times_path, out;
  app.add_option("poses", poses, "KITTI poses file")->required()->check(CLI::ExistingFile);
  app.add_option("--times", times_path, "KITTI times.txt, one time [s] a line")->check(CLI::ExistingFile);
  app.add_option("--out", out, "TUM trajectory to write")->required()->check(NonEmptyPath());
  CLI11_PARSE(app, argc, argv);
  std::vector<double> times;
  if (!times_path.empty()) {
    times = stereo::ReadKittiTimes(times_path);
  } else {
    std::ifstream in(poses);
    std::string line;
    for (size_t n = 0; std::getline(in, line);)
      if (line.find_first_not_of(" \t\r") != std::string::npos) times.push_back(0.1 * n++);
  }
  const Trajectory trajectory = stereo::ReadKittiPoses(poses, times);
  if (std::filesystem::path(out).has_parent_path()) std::filesystem::create_directories(std::filesystem::path(out).parent_path());
  WriteTumTrajectory(out, trajectory);
  std::printf("wrote %s: %zu poses\n", out.c_str(), trajectory.size());
  return 0;
}

}  // namespace

DYPHO_COMMAND("kitti-to-tum", "convert a KITTI poses file to a TUM trajectory", RunKittiToTum);
DYPHO_COMMAND("eval", "trajectory accuracy: ATE and RPE as in the TUM RGB-D benchmark", RunEval);
DYPHO_COMMAND("dataset-info", "describe an RGB-D dataset folder (frames, camera, depth, ground truth)",
              RunDatasetInfo);

}  // namespace dypho::tools
