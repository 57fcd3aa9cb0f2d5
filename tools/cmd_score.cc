// dypho score: the independent score of a map against real frames
// (engine/eval/map_score.h): PSNR, SSIM, depth L1 and coverage of the plain
// render at given poses, and the colour-aligned PSNR/SSIM beside them.
#include <cstdio>
#include <algorithm>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/check.h"
#include "common/files.h"
#include "common/progress.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/map_score.h"
#include "engine/eval/plots.h"
#include "engine/export/export.h"
#include "engine/io/image_io.h"
#include "tools/command.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

int RunScore(int argc, char** argv) {
  CLI::App app{"Score a Gaussian map against the real frames of a dataset: render it at every n-th frame's pose and "
               "compare (PSNR, SSIM, depth L1, coverage; plain and per-frame colour-aligned)."};
  std::string map_path, trajectory = "gt", dataset_path, keyframes_path, out_dir;
  bool write_into_dataset = false;
  MapScoreOptions options;
  int pictures = 8;
  bool include_masked = false, save_renders = false;
  app.add_option("map", map_path, "Gaussian map: .ply (3DGS), .splat, .glb or .gltf")->required()->check(CLI::ExistingFile);
  app.add_option("--dataset", dataset_path, "dataset folder with the real frames (TUM/Bonn layout or generic)")
      ->required()
      ->check(CLI::ExistingDirectory);
  DatasetOptions dataset_options;
  AddDepthTimeOption(app, &dataset_options.depth_time);
  app.add_option("--trajectory", trajectory,
                 "camera poses in the map's frame: a TUM trajectory file (world_from_cam), or gt for the dataset's "
                 "ground truth")
      ->capture_default_str();
  app.add_option("--keyframes", keyframes_path,
                 "the map's keyframes (TUM file, e.g. keyframes.txt of dypho run): their frames are reported apart "
                 "(trained on) from the novel views")
      ->check(CLI::ExistingFile);
  app.add_option("--every", options.every, "score every n-th dataset frame")->capture_default_str()->check(CLI::Range(1, 1000000));
  app.add_option("--first-frame", options.first_frame, "first dataset frame considered")->capture_default_str();
  app.add_option("--max-frames", options.max_frames, "dataset frames considered (0 = all)")->capture_default_str();
  app.add_option("--downscale", options.eval_downscale, "score at 1/n resolution")->capture_default_str()->check(CLI::Range(1, 8));
  std::vector<float> depth_range;
  app.add_option("--depth-range", depth_range,
                 "MIN MAX [m]: score depth only where the frame's depth is in this range (the range the map was "
                 "built from; `dypho run` uses the preset's mapper.min_depth/max_depth)")
      ->expected(2);
  app.add_option("--background", options.background, "background grey level of the renders [0, 1]")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--threads", options.num_threads,
                 "CPU threads (0 = all cores, at most " + std::to_string(kMaxThreads) + ")")
      ->capture_default_str()
      ->check(CLI::Range(0, kMaxThreads));
  app.add_option("--readout", options.sensor.readout,
                 "rolling-shutter readout of the camera [s] (TUM fr1 Kinect: 0.025): adds a column with the render "
                 "through the sensor model")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--exposure", options.sensor.exposure, "exposure time of the sensor model's blur [s]")
      ->check(CLI::Range(0.0, 1.0));
  app.add_flag("--include-masked", include_masked, "also score pixels the dataset's masks/ mark dynamic");
  app.add_option("--out", out_dir, "folder for scores.csv, score.md and score.png (optional)")->check(NonEmptyPath());
  app.add_flag("--write-into-dataset", write_into_dataset,
               "allow the output inside the input dataset folder (refused otherwise: it could overwrite its files)");
  app.add_flag("--save-renders", save_renders, "also write every render and real frame to OUT/renders/");
  app.add_option("--pictures", pictures, "frames shown in score.png (lowest PSNR first)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  CLI11_PARSE(app, argc, argv);
  if (!out_dir.empty()) CheckOutsideDataset(out_dir, dataset_path, "--out", write_into_dataset);
  options.exclude_dataset_masks = !include_masked;
  if (depth_range.size() == 2) options.min_depth = depth_range[0], options.max_depth = depth_range[1];
  options.Validate();

  const GaussianCloud cloud = LoadMap(map_path);
  const std::unique_ptr<Dataset> dataset = OpenDataset(dataset_path, dataset_options);
  Trajectory poses;
  if (trajectory == "gt") {
    DYPHO_CHECK_INPUT(dataset->has_ground_truth())
        << "dataset " << dataset_path << " has no groundtruth.txt: give --trajectory FILE";
    poses = dataset->ground_truth();
  } else {
    DYPHO_CHECK_INPUT(std::filesystem::is_regular_file(trajectory))
        << "--trajectory " << trajectory << " is not a file (give a TUM trajectory file or gt)";
    poses = ReadTumTrajectory(trajectory);
  }
  if (!keyframes_path.empty()) options.trained_timestamps = ReadTumTrajectory(keyframes_path).timestamps;

  std::vector<std::pair<double, FramePair>> shown;  // (psnr, pair)
  MapScoreVisitor visit;
  if (!out_dir.empty() && (pictures > 0 || save_renders)) {
    visit = [&](const FrameMapScore& s, const ImageU8& rendered, const ImageU8& real) {
      if (save_renders) {
        const std::filesystem::path dir = std::filesystem::path(out_dir) / "renders";
        MakeDirectories(dir.string());
        WriteRgb8((dir / (std::to_string(s.frame) + "_render.png")).string(), rendered);
        WriteRgb8((dir / (std::to_string(s.frame) + "_real.png")).string(), real);
      }
      if (pictures == 0) return;
      char caption[160];
      std::snprintf(caption, sizeof(caption), "frame %zu%s: %.2f dB, depth %.1f cm", s.frame,
                    s.trained ? " (keyframe)" : "", s.psnr, 100 * s.depth_l1);
      shown.push_back({s.psnr, FramePair{rendered, real, caption}});
      std::sort(shown.begin(), shown.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      if (static_cast<int>(shown.size()) > pictures) shown.pop_back();
    };
  }
  std::optional<Progress> progress;
  const MapScore score = ScoreMap(
      cloud, *dataset, poses, options,
      [&](size_t done, size_t total) {
        if (!progress) progress.emplace("score " + dataset->name(), static_cast<long>(total));
        progress->Advance(static_cast<long>(done) - progress->done());
      },
      visit);
  if (progress) progress->Finish();

  const std::string table = FormatMapScoreTable(score);
  std::printf("%s", table.c_str());
  if (!score.uncovered.empty())
    std::printf("%zu of the chosen frames have no pose in the trajectory (not scored)\n", score.uncovered.size());
  if (!out_dir.empty()) {
    MakeDirectories(out_dir);
    const std::filesystem::path out(out_dir);
    WriteTextAtomically((out / "scores.csv").string(), FormatMapScoreCsv(score));
    WriteTextAtomically((out / "score.md").string(),
                        "# dypho score: " + map_path + " on " + dataset->name() + "\n\n" + table +
                            "\nPer frame: `scores.csv`. Lowest-PSNR frames, render beside the real frame: "
                            "`score.png`.\n");
    if (!shown.empty()) {
      std::vector<FramePair> pairs;
      for (auto& [psnr, pair] : shown) pairs.push_back(std::move(pair));
      WritePlot((out / "score.png").string(), DrawFrameGrid(pairs));
    }
    std::printf("wrote %s\n", (out / "score.md").string().c_str());
  }
  return 0;
}

}  // namespace

DYPHO_COMMAND("score", "score a map against real frames: PSNR/SSIM/depth L1 of renders at given poses", RunScore);

}  // namespace dypho::tools
