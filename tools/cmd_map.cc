// dypho map: builds a Gaussian map of an RGB-D sequence with given poses
// (ground truth, a TUM trajectory file, or the ORB tracker), evaluates it on
// keyframes and held-out frames, and writes the map, trajectory and scores.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <CLI/CLI.hpp>

#include "common/check.h"
#include "common/files.h"
#include "common/logging.h"
#include "common/progress.h"
#include "engine/dataset/dataset.h"
#include "engine/export/ply.h"
#include "engine/map/map_sequence.h"
#include "engine/map/map_report.h"
#include "tools/command.h"
#include "tools/option_sets.h"
#include "tracker/orb_tracker.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

int RunMap(int argc, char** argv) {
  CLI::App app{"Build a static Gaussian map of an RGB-D sequence with known or tracked poses."};
  std::string dataset_dir, out_dir = "map_out", poses = "gt";
  bool write_into_dataset = false;
  SequenceMappingOptions opt;
  MapperOptions& m = opt.mapper;
  int threads = 0;
  bool no_masks = false, no_eval = false;
  app.add_option("dataset", dataset_dir, "dataset folder (TUM/Bonn layout or generic)")->required();
  DatasetOptions dataset_options;
  AddDepthTimeOption(app, &dataset_options.depth_time);
  app.add_option("--out", out_dir, "output folder")->capture_default_str()->check(NonEmptyPath());
  app.add_flag("--write-into-dataset", write_into_dataset,
               "allow the output inside the input dataset folder (refused otherwise: it could overwrite its files)");
  app.add_option("--poses", poses, "gt (ground truth), orb (the ORB tracker) or a TUM trajectory file")
      ->capture_default_str();
  app.add_option("--iterations", opt.iterations_per_keyframe, "optimisation steps per keyframe")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--final-iterations", opt.final_iterations, "steps over all keyframes at the end")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--max-frames", opt.max_frames, "use at most this many frames (0 = all)")->capture_default_str();
  app.add_option("--first-frame", opt.first_frame, "first frame used")->capture_default_str();
  app.add_option("--frame-step", opt.frame_step, "use every n-th frame")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--heldout-every", opt.heldout_every, "evaluate every n-th non-keyframe (0 = none)")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--kf-translation", opt.keyframes.max_translation, "keyframe after this camera motion [m]")
      ->capture_default_str();
  app.add_option("--kf-rotation", opt.keyframes.max_rotation_deg, "keyframe after this rotation [deg]")
      ->capture_default_str();
  app.add_option("--kf-gap", opt.keyframes.max_frame_gap, "keyframe at least every n frames")->capture_default_str();
  app.add_option("--kf-new-content", opt.keyframes.min_new_content,
                 "keyframe when this fraction of the frame is seen by no keyframe (0 = motion rules only)")
      ->capture_default_str();
  app.add_option("--kf-window", opt.keyframes.sharpness_window, "a keyframe is the sharpest of this many frames")
      ->capture_default_str();
  app.add_option("--kf-sharper", opt.keyframes.sharper_ratio,
                 "keyframe when a frame is this many times sharper than the keyframes that see it (0 = off)")
      ->capture_default_str();
  app.add_option("--kf-tail", opt.keyframes.tail_new_content,
                 "at the end, the newest frame since the last keyframe seeing this fraction of new content is one (0 = off)")
      ->capture_default_str();
  app.add_option("--train-downscale", m.train_downscale, "optimise at 1/n resolution")->capture_default_str();
  app.add_option("--refine-downscale", opt.mapper.refine_downscale,
                 "final refinement at 1/n resolution (0 = as --train-downscale)")
      ->capture_default_str();
  app.add_option("--sh-degree", m.sh_degree, "SH degree of the map (0..3)")->capture_default_str();
  app.add_option("--insert-stride", m.insert_stride, "grid step of new Gaussians [training px]")->capture_default_str();
  app.add_option("--insert-scale", m.insert_scale_factor, "initial std of new Gaussians [insert grid cells]")
      ->capture_default_str();
  app.add_option("--insert-opacity", m.insert_opacity, "initial opacity of new Gaussians")->capture_default_str();
  app.add_option("--lr-scale", m.lr_log_scales, "Adam rate of the log-scales")->capture_default_str();
  app.add_option("--lr-means", m.lr_means, "Adam rate of the means [m/step]")->capture_default_str();
  app.add_option("--lr-opacity", m.lr_opacity, "Adam rate of the opacity logits")->capture_default_str();
  app.add_option("--lr-color", m.lr_sh_dc, "Adam rate of the base colour")->capture_default_str();
  app.add_option("--carve-votes", opt.carve_votes,
                 "before the final refinement remove Gaussians this many other keyframes see through (0 = off)")
      ->capture_default_str();
  app.add_option("--sharp-sampling", m.sharp_sampling_floor,
                 "final refinement draws blurred keyframes down to this weight (1 = uniform)")
      ->capture_default_str();
  app.add_option("--densify-every", m.densify_every, "densify/prune every n steps (0 = never)")->capture_default_str();
  app.add_option("--densify-grad", m.densify_grad_threshold, "densification gradient threshold")->capture_default_str();
  app.add_option("--depth-weight", m.depth_weight, "weight of the depth L1 term")->capture_default_str();
  app.add_option("--lambda-ssim", m.lambda_ssim, "weight of (1 - SSIM)")->capture_default_str();
  bool no_fill = false;
  int renders = 8;
  app.add_option("--renders", renders, "keyframes shown in renders.png")->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_flag("--no-fill-depth", no_fill, "no Gaussians for static pixels without a depth reading");
  app.add_option("--readout", m.sensor.readout,
                 "rolling-shutter readout, first to last row [s] (0 = global shutter; TUM fr1 Kinect: about 0.025)")
      ->capture_default_str();
  app.add_option("--exposure", m.sensor.exposure, "exposure time for the motion-blur model [s] (0 = no blur)")
      ->capture_default_str();
  app.add_option("--align-heldout", opt.align_heldout_iterations,
                 "align each held-out frame's pose and exposure to the map in this many steps before scoring (0 = no)")
      ->capture_default_str();
  app.add_option("--blur-samples", m.sensor.max_samples, "most time samples of the motion-blur model")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_flag("--refine-exposure", m.refine_exposure, "learn each keyframe's colour response (auto exposure)");
  app.add_flag("--refine-poses", m.refine_poses, "refine keyframe poses photometrically");
  app.add_flag("--no-masks", no_masks, "ignore the dataset's dynamic masks");
  app.add_flag("--no-eval", no_eval, "skip the evaluation renders");
  app.add_flag("--strict", opt.strict,
               "stop at the first frame that cannot be read (outputs written for the frames before it, exit code 2) "
               "instead of skipping it with a warning");
  app.add_option("--threads", threads, "CPU threads (0 = all cores, at most " + std::to_string(kMaxThreads) + ")")
      ->capture_default_str()
      ->check(CLI::Range(0, kMaxThreads));
  std::vector<std::string> sets;
  app.add_option("--set", sets,
                 "override one mapper option: mapper.KEY=VALUE (repeatable; the keys of `dypho run --print-config`), "
                 "e.g. --set mapper.device=cuda; applied after the flags");
  CLI11_PARSE(app, argc, argv);
  m.num_threads = threads;
  m.insert_without_depth = !no_fill;
  opt.use_dataset_masks = !no_masks;
  opt.evaluate = !no_eval;
  ApplyPartSets(sets, "mapper.", &PipelineOptions::mapper, &m, "dypho map");

  CheckOutsideDataset(out_dir, dataset_dir, "--out", write_into_dataset);
  const std::unique_ptr<Dataset> data = OpenDataset(dataset_dir, dataset_options);
  const Dataset& dataset = *data;
  PoseSource source;
  std::unique_ptr<OrbTracker> tracker;
  if (poses == "gt") {
    source.kind = PoseSource::Kind::kGroundTruth;
  } else if (poses == "orb") {
    source.kind = PoseSource::Kind::kTracker;
    tracker = std::make_unique<OrbTracker>(dataset.camera());
    source.tracker = tracker.get();
  } else {
    source.kind = PoseSource::Kind::kTrajectory;
    source.trajectory = ReadTumTrajectory(poses);
    source.trajectory_path = poses;
  }
  MakeOutputDirectory(out_dir);
  ClearOwnedOutputs(out_dir, kMappingOutputs);
  const size_t total = opt.max_frames ? std::min(opt.max_frames, dataset.size()) : dataset.size();
  Progress progress("map", total / opt.frame_step);
  std::unique_ptr<Mapper> mapper;
  const SequenceMappingResult result = MapSequence(
      dataset, source, opt, &mapper,
      [&](size_t done, size_t, const std::string& msg) {
        progress.Advance(static_cast<long>(done) - progress.done(), msg);
      });
  progress.Finish();
  WriteMappingOutputs(out_dir, dataset, result, *mapper, renders);
  std::printf("%s\n", FormatMappingSummary(result).c_str());
  std::printf("wrote %s/{map.ply,dense.ply,trajectory.txt,report.md,scores.csv,renders.png,loss.png}\n", out_dir.c_str());
  if (!result.stopped_at.empty()) {
    std::fprintf(stderr, "dypho map: error: stopped at an unreadable frame (--strict); outputs written for the frames "
                         "before it: %s\n", result.stopped_at.c_str());
    return 2;
  }
  return 0;
}

DYPHO_COMMAND("map", "build a Gaussian map of a sequence with known or tracked poses", RunMap);

}  // namespace
}  // namespace dypho::tools
