// `dypho run`: the whole dynamic SLAM system (engine/pipeline/pipeline.h),
// and `dypho ablate`: its ablation table.
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <string>
#include <unistd.h>
#include <vector>

#include "common/check.h"
#include "common/files.h"
#include "engine/dataset/dataset.h"
#include "engine/pipeline/pipeline.h"
#include "tools/command.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

std::atomic<bool> g_stop{false};

// First Ctrl-C: finish the current frame and write the outputs of what was
// processed. Second: leave at once (outputs already written stay valid:
// every file is written atomically).
extern "C" void OnInterrupt(int) {
  if (g_stop.exchange(true)) _exit(130);
  const char message[] = "\ndypho: interrupted; writing the outputs of the frames processed (Ctrl-C again to quit)\n";
  const ssize_t ignored = write(2, message, sizeof(message) - 1);
  (void)ignored;
}

struct RunFlags {
  std::string dataset, out_dir, config, poses, preset, stereo_method = "elas", depth_time = "auto";
  std::vector<std::string> sets, disable;
  std::string model;
  bool sequential = false, print_config = false, strict = false, write_into_dataset = false, realtime = false;
  long max_frames = -1;
};

void AddCommonFlags(CLI::App& app, RunFlags& f) {
  app.add_option("dataset", f.dataset,
                 "dataset folder (TUM, Bonn, generic with camera.yaml, or a synthetic sequence); none = generate "
                 "and run the built-in synthetic dynamic sequence");
  app.add_option("--out", f.out_dir, "output folder (created)")->required()->check(NonEmptyPath());
  app.add_flag("--write-into-dataset", f.write_into_dataset,
               "allow the output inside the input dataset folder (refused otherwise: it could overwrite its files)");
  app.add_option("--config", f.config, "options file (YAML or JSON); see --print-config for every key");
  app.add_option("--stereo-method", f.stereo_method, "stereo datasets: disparity by elas (ours) or sgbm (OpenCV)")
      ->capture_default_str()->check(CLI::IsMember({"elas", "sgbm"}));
  AddDepthTimeOption(app, &f.depth_time);
  app.add_option("--preset", f.preset, "synthetic|tum|bonn|shore|stereo (default: from the dataset, or the config file)");
  app.add_option("--poses", f.poses, "orb (the ORB tracker, default), gt (ground truth) or a TUM trajectory file");
  app.add_option("--model", f.model,
                 "ONNX detector for the semantic mask (YOLOX or YOLOv8-seg), e.g. "
                 "../shared/data/models/yolox_nano.onnx; same as --set masking.segmenter.model_path=FILE");
  app.add_option("--set", f.sets, "override one option: key=value (repeatable), e.g. --set masking.flow.scale=0.25");
  app.add_option("--disable", f.disable, "switch a part off: refine|adaptive|semantic|flow|epipolar|shore|masking|local-ba|loops (repeatable)");
  app.add_flag("--sequential", f.sequential, "mapping and detector on the tracking thread: identical results run to run");
  app.add_flag("--realtime", f.realtime,
               "replay the dataset at its own timestamps as a live camera would, dropping frames when tracking is "
               "slower (counted in the report); same as --set realtime=true (rate: --set realtime_speed=X)");
  app.add_flag("--strict", f.strict,
               "stop at the first frame that cannot be read, as Ctrl-C does (outputs written for the frames before "
               "it, exit code 2), instead of skipping it with a warning; same as --set strict_frames=true");
  app.add_option("--max-frames", f.max_frames, "process at most N frames (0 = all)");
  app.add_flag("--print-config", f.print_config, "print every option with its value, units and range, then exit");
}

// Options: preset (flag, else config's, else the dataset's), config file, flags.
PipelineOptions ResolveOptions(const RunFlags& f, const Dataset* dataset) {
  std::string preset = f.preset;
  if (preset.empty()) preset = dataset ? PresetForDataset(*dataset) : "synthetic";
  PipelineOptions options = PresetOptions(preset);
  if (!f.config.empty()) ApplyConfigFile(&options, f.config);
  if (!f.preset.empty() && options.preset != f.preset) {
    // --preset wins over the file's preset key; the file's other keys stay applied on top.
    PipelineOptions p = PresetOptions(f.preset);
    if (!f.config.empty()) ApplyConfigFile(&p, f.config);
    p.preset = f.preset;
    options = p;
  }
  if (!f.poses.empty()) SetOption(&options, "poses", f.poses, "--poses");
  if (!f.model.empty()) SetOption(&options, "masking.segmenter.model_path", f.model, "--model");
  if (f.sequential) options.sequential = true;
  if (f.strict) options.strict_frames = true;
  if (f.realtime) options.realtime = true;
  if (f.max_frames >= 0) SetOption(&options, "max_frames", std::to_string(f.max_frames), "--max-frames");
  for (const std::string& s : f.sets) SetOptionAssignment(&options, s);
  for (const std::string& d : f.disable) DisableStage(&options, d);
  options.Validate();
  return options;
}

// Opens the given dataset (its folder decides the preset), or generates the
// built-in sequence; `options` receives the resolved options tree.
std::unique_ptr<Dataset> OpenOrGenerate(const RunFlags& f, PipelineOptions* options) {
  if (!f.dataset.empty()) {
    CheckOutsideDataset(f.out_dir, f.dataset, "--out", f.write_into_dataset);
    DatasetOptions dataset_options;
    dataset_options.stereo_method = f.stereo_method;
    dataset_options.depth_time = f.depth_time;
    std::unique_ptr<Dataset> dataset = OpenDataset(f.dataset, dataset_options);
    *options = ResolveOptions(f, dataset.get());
    return dataset;
  }
  *options = ResolveOptions(f, nullptr);
  const std::string dir = (std::filesystem::path(f.out_dir) / "sequence").string();
  const bool shore = options->synth_scene == "shore";
  std::fprintf(stderr, "dypho: no dataset given: generating the built-in %s (%d frames, %dx%d, %d %s) in %s\n",
               shore ? "synthetic harbour" : "synthetic dynamic sequence", options->synth.frames,
               options->synth.width, options->synth.height, options->synth.num_walkers,
               shore ? "pedestrians and a boat" : "walkers", dir.c_str());
  return MakeBuiltInSequence(*options, dir);
}

void PrintSummary(const PipelineResult& r) {
  if (!r.unreadable_frames.empty()) std::printf("%zu unreadable frames skipped\n", r.unreadable_frames.size());
  std::printf("%s: %ld frames (%ld with a pose)%s, %d keyframes (%d mapped late, none dropped), %d Gaussians\n", r.dataset.c_str(),
              r.frames, r.tracked, r.interrupted ? ", interrupted" : "", r.keyframes, r.late_keyframes,
              r.num_gaussians);
  if (r.has_ate) std::printf("ATE RMSE %.2f cm", 100 * r.ate_rmse);
  if (r.has_rpe) std::printf(", RPE %.2f cm/s %.2f deg/s", 100 * r.rpe_translation_rmse, r.rpe_rotation_rmse);
  if (r.has_ate) std::printf("\n");
  std::printf("PSNR %.2f dB, SSIM %.3f on static pixels (%d frames)\n", r.psnr, r.ssim, r.scored_frames);
  std::printf("tracking %.1f frames/s (masks %.1f ms, tracker %.1f ms, map render %.1f ms per frame), largest "
              "mapping backlog %d, mapping finished %.1f s after the last frame\n",
              r.tracking_fps, r.timings.mask_ms, r.timings.track_ms, r.timings.render_ms, r.max_backlog,
              r.finish_seconds);
  std::printf("report %s\n", r.report_path.c_str());
}

int RunRun(int argc, char** argv) {
  CLI::App app{
      "Run the whole dynamic SLAM system: dynamic masks (semantic + flow + epipolar, refined by the map's "
      "background depth), ORB tracking with mask weights and adaptive features, keyframes, Gaussian mapping in its "
      "own thread. Writes trajectory.txt, map.ply/.splat/.glb, renders/, overlays/, report.md, metrics.json.",
      "dypho run"};
  RunFlags f;
  AddCommonFlags(app, f);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (f.print_config) {
    std::printf("%s", FormatOptions(ResolveOptions(f, nullptr)).c_str());
    return 0;
  }
  PipelineOptions options;
  const std::unique_ptr<Dataset> dataset = OpenOrGenerate(f, &options);
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  PipelineHooks hooks;
  hooks.stop = &g_stop;
  const PipelineResult result = RunPipeline(options, *dataset, f.out_dir, hooks);
  PrintSummary(result);
  if (!result.stopped_at.empty()) {
    std::fprintf(stderr, "dypho run: error: stopped at an unreadable frame (--strict); outputs written for the frames "
                         "before it: %s\n", result.stopped_at.c_str());
    return 2;
  }
  return result.interrupted ? 130 : 0;
}

int RunAblate(int argc, char** argv) {
  CLI::App app{
      "Run the ablation table of DyPho-SLAM on a dataset: no masking; masks without refinement and with fixed FAST "
      "thresholds; + mask refinement; + adaptive features; the full system. With --preset shore the nearshore "
      "paper's rows: no masks, shore mask only, shore + semantic, shore + semantic + epipolar (and, on the "
      "synthetic harbour, features per frame on water, sky and moving things). Writes OUT/row*/ (each a dypho run "
      "output) and OUT/ablation.md.",
      "dypho ablate"};
  RunFlags f;
  AddCommonFlags(app, f);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  PipelineOptions options;
  const std::unique_ptr<Dataset> dataset = OpenOrGenerate(f, &options);
  std::signal(SIGINT, OnInterrupt);
  PipelineHooks hooks;
  hooks.stop = &g_stop;
  const std::vector<AblationRow> rows = RunAblation(options, *dataset, f.out_dir, hooks);
  for (const AblationRow& row : rows) {
    std::printf("%-40s ATE %s cm, PSNR %.2f dB, tracked %ld/%ld\n", row.name.c_str(),
                row.result.has_ate ? std::to_string(100 * row.result.ate_rmse).c_str() : "-", row.result.psnr,
                row.result.tracked, row.result.frames);
    if (row.has_feature_classes) {
      const FeatureClassCounts& c = row.feature_classes;
      std::printf("%-40s features per frame %.1f: on water %.1f, sky %.1f, moving %.1f\n", "", c.PerFrame(c.features),
                  c.PerFrame(c.water), c.PerFrame(c.sky), c.PerFrame(c.dynamic));
    }
  }
  std::printf("table %s/ablation.md\n", f.out_dir.c_str());
  return 0;
}

}  // namespace

DYPHO_COMMAND("run", "the whole dynamic SLAM system on a dataset (or the built-in synthetic sequence)", RunRun);
DYPHO_COMMAND("ablate", "DyPho-SLAM's ablation table on a dataset (runs dypho run per variant)", RunAblate);

}  // namespace dypho::tools
