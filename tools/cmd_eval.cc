// `dypho eval`: trajectory accuracy (ATE, RPE) as in the TUM RGB-D benchmark.
// `dypho dataset-info`: what a dataset folder holds.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <string>

#include "common/logging.h"
#include "engine/dataset/dataset.h"
#include "engine/dataset/dataset_info.h"
#include "engine/eval/ate.h"
#include "engine/eval/plots.h"
#include "engine/eval/report.h"
#include "engine/eval/trajectory.h"
#include "tools/command.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

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
                 "ground-truth trajectory (TUM format), or a dataset folder holding groundtruth.txt")
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

  if (std::filesystem::is_directory(gt_path))
    gt_path = (std::filesystem::path(gt_path) / "groundtruth.txt").string();
  const Trajectory ground_truth = ReadTumTrajectory(gt_path);
  const Trajectory estimate = ReadTumTrajectory(est_path);
  for (const auto& [path, poses] : {std::pair<const std::string&, const Trajectory&>{gt_path, ground_truth},
                                    {est_path, estimate}}) {
    DYPHO_CHECK_INPUT(!poses.empty()) << path << " holds no poses (expected lines 'timestamp tx ty tz qx qy qz qw')";
  }
  TrajectoryEvaluation evaluation = EvaluateTrajectory(ground_truth, estimate, ate, rpe);
  evaluation.ground_truth_path = gt_path;
  evaluation.estimate_path = est_path;
  std::printf("%s", FormatEvaluation(evaluation).c_str());
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

}  // namespace

DYPHO_COMMAND("eval", "trajectory accuracy: ATE and RPE as in the TUM RGB-D benchmark", RunEval);
DYPHO_COMMAND("dataset-info", "describe an RGB-D dataset folder (frames, camera, depth, ground truth)",
              RunDatasetInfo);

}  // namespace dypho::tools
