// `dypho masks`: dynamic masks of a dataset's frames, written as PNGs for
// inspection (mask PNGs and overlays: the mask tinted over the image).
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "common/check.h"
#include "common/files.h"
#include "common/progress.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/image_metrics.h"
#include "engine/io/image_io.h"
#include "engine/pipeline/pipeline_options.h"
#include "masking/coco_classes.h"
#include "masking/dynamic_masker.h"
#include "tools/command.h"
#include "tracker/cv_view.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

// An owning copy of a continuous CV_8UC1/CV_8UC3 image.
ImageU8 ToImage(const cv::Mat& mat) {
  ImageU8 image(mat.cols, mat.rows, mat.channels());
  const cv::Mat view(mat.rows, mat.cols, mat.type(), image.data());
  mat.copyTo(view);
  return image;
}

struct StageTotals {
  MaskTimings sum;
  long frames = 0;
  void Add(const MaskTimings& t) {
    sum.flow_ms += t.flow_ms;
    sum.semantic_ms += t.semantic_ms;
    sum.epipolar_ms += t.epipolar_ms;
    sum.background_ms += t.background_ms;
    sum.shore_ms += t.shore_ms;
    sum.total_ms += t.total_ms;
    ++frames;
  }
  std::string Format() const {
    const double n = frames > 0 ? frames : 1;
    char line[400];
    std::snprintf(line, sizeof(line),
                  "mean per frame [ms]: semantic %.1f, flow %.1f, epipolar %.1f, background %.1f, shore %.1f, "
                  "total %.1f",
                  sum.semantic_ms / n, sum.flow_ms / n, sum.epipolar_ms / n, sum.background_ms / n, sum.shore_ms / n,
                  sum.total_ms / n);
    return line;
  }
};

int RunMasks(int argc, char** argv) {
  CLI::App app{
      "Dynamic masks of an RGB-D dataset (semantic prior from a detector or PNG folder, flow motion, epipolar "
      "check, background-depth refinement). Writes masks/<image>.png (255 = dynamic) and "
      "overlays/<image>.png (mask tinted red, detections yellow, features green/red) and summary.txt; with "
      "ground-truth masks in the dataset, prints their IoU.",
      "dypho masks"};
  std::string folder, out_dir, classes = "person";
  bool write_into_dataset = false;
  MaskingOptions options;
  DatasetOptions dataset_options;
  bool threaded = false, no_flow = false, no_epipolar = false, no_background = false, shore = false;
  bool no_overlays = false, gt_as_is = false;
  long max_frames = 0;
  double max_gap = 0.5;
  std::vector<std::string> sets;
  app.add_option("dataset", folder, "dataset folder (TUM, Bonn, or generic with camera.yaml)")->required();
  app.add_option("--out", out_dir, "output folder (created if needed)")->required()->check(NonEmptyPath());
  app.add_flag("--write-into-dataset", write_into_dataset,
               "allow the output inside the input dataset folder (refused otherwise: it could overwrite its files)");
  app.add_option("--camera-preset", dataset_options.camera_preset,
                 "freiburg1|freiburg2|freiburg3|bonn (default: from the folder's camera file or name)");
  app.add_option("--camera-file", dataset_options.camera_file, "YAML/JSON camera file (default: auto)");
  app.add_option("--model", options.segmenter.model_path,
                 "ONNX detector: YOLOX (e.g. ../shared/data/models/yolox_nano.onnx) or YOLOv8-seg; none = no "
                 "semantic mask");
  app.add_option("--png-masks", options.segmenter.png_folder,
                 "folder of semantic masks <image name>.png made offline (instead of --model)");
  app.add_option("--every", options.schedule.interval,
                 "run the detector every N frames; masks in between are carried by the optical flow")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_flag("--threaded", threaded, "run the detector in its own thread (masks carried by the flow)");
  app.add_option("--classes", classes, "dynamic COCO classes, comma-separated; 'moving' = people, animals, vehicles")
      ->capture_default_str();
  app.add_option("--score", options.segmenter.score_threshold, "detection score threshold")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_flag("--no-flow", no_flow, "no flow-motion mask");
  app.add_flag("--no-epipolar", no_epipolar, "no epipolar check of features");
  app.add_flag("--no-background", no_background, "no background-depth refinement");
  app.add_flag("--shore", shore, "mask water and sky (boats, docks)");
  app.add_flag("--no-overlays", no_overlays, "write masks only");
  app.add_option("--set", sets,
                 "override one masking option: masking.KEY=VALUE (repeatable; the keys of `dypho run "
                 "--print-config`), e.g. --set masking.background.min_support=4; applied after the flags");
  app.add_flag("--gt-poses-as-is", gt_as_is,
               "use the ground-truth relative poses for the flow mask without refining them on the flow");
  app.add_option("--max-frames", max_frames, "process at most this many frames (0 = all)")->capture_default_str();
  app.add_option("--max-gap", max_gap,
                 "frames further apart than this [s] start a new sequence (no flow across the gap)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  options.segmenter.classes = ParseClassList(classes);
  options.schedule.threaded = threaded;
  options.use_flow = !no_flow;
  options.use_epipolar = !no_epipolar;
  options.use_background = !no_background;
  options.use_shore = shore;
  if (!sets.empty()) {
    PipelineOptions tree;
    tree.masking = options;
    for (const std::string& s : sets) {
      DYPHO_CHECK_INPUT(s.rfind("masking.", 0) == 0)
          << "--set " << s << ": dypho masks takes only masking.* keys (see dypho run --print-config)";
      SetOptionAssignment(&tree, s);
    }
    options = tree.masking;
  }

  CheckOutsideDataset(out_dir, folder, "--out", write_into_dataset);
  const std::unique_ptr<Dataset> dataset = OpenDataset(folder, dataset_options);
  // The flow mask starts from the ground-truth relative poses when the
  // dataset has them and refines them on the flow (motion-capture poses
  // interpolated to the image times are a few tenths of a degree off during
  // fast motion: on TUM fr1/rpy, as they are, they mark half of a static
  // image as moving; refined, a tenth); without ground truth the pose is
  // estimated from the flow alone.
  const bool use_gt = dataset->has_ground_truth();
  options.flow.estimate_pose = !(use_gt && gt_as_is);
  DynamicMasker masker(options, dataset->camera());
  const std::string masks_dir = (std::filesystem::path(out_dir) / "masks").string();
  const std::string overlays_dir = (std::filesystem::path(out_dir) / "overlays").string();
  MakeDirectories(masks_dir);
  if (!no_overlays) MakeDirectories(overlays_dir);

  const long total = max_frames > 0 ? std::min<long>(max_frames, dataset->size()) : dataset->size();
  std::printf("%s: %ld frames, camera %s, segmenter %s, poses for the flow: %s\n", dataset->name().c_str(), total,
              dataset->camera_source().c_str(), masker.segmenter_name().c_str(),
              use_gt ? (gt_as_is ? "ground truth" : "ground truth refined on the flow") : "estimated from the flow");
  Progress progress("masks " + dataset->name(), total);
  StageTotals timings;
  MaskScores raw_scores, final_scores;
  long scored = 0;
  double prev_time = -1e300;
  std::optional<Rigid3d> prev_pose;
  for (long i = 0; i < total; ++i) {
    const Frame frame = dataset->Load(static_cast<size_t>(i));
    if (frame.timestamp - prev_time > max_gap) {
      masker.Reset();
      prev_pose.reset();
    }
    MaskerInput input;
    input.rgb = CvView(frame.rgb);
    if (frame.has_depth) input.depth = CvView(frame.depth);
    input.name = std::filesystem::path(frame.rgb_path).stem().string();
    if (use_gt && frame.world_from_cam_gt && prev_pose)
      input.cam_from_prev = frame.world_from_cam_gt->Inverse() * *prev_pose;
    prev_pose = frame.world_from_cam_gt;
    prev_time = frame.timestamp;
    const MaskResult result = masker.Process(input);
    timings.Add(result.timings);

    WriteGray8((std::filesystem::path(masks_dir) / (input.name + ".png")).string(), ToImage(result.mask));
    if (!no_overlays)
      WriteRgb8((std::filesystem::path(overlays_dir) / (input.name + ".png")).string(),
                ToImage(DrawMaskOverlay(input.rgb, result)));
    if (!frame.dynamic_mask.empty()) {
      raw_scores += CompareMasks(ToImage(result.raw_mask), frame.dynamic_mask);
      final_scores += CompareMasks(ToImage(result.mask), frame.dynamic_mask);
      ++scored;
    }
    char extra[96];
    std::snprintf(extra, sizeof(extra), "%zu detections, %.0f ms", result.detections.size(), result.timings.total_ms);
    progress.Advance(1, extra);
  }
  progress.Finish();

  std::ostringstream summary;
  summary << "dataset " << folder << "\nframes " << total << "\nsegmenter " << masker.segmenter_name() << "\n"
          << timings.Format() << "\n";
  if (scored > 0) {
    char line[200];
    std::snprintf(line, sizeof(line),
                  "IoU against the dataset's masks over %ld frames: raw %.3f, final %.3f (precision %.3f, "
                  "recall %.3f)\n",
                  scored, raw_scores.Iou(), final_scores.Iou(), final_scores.Precision(), final_scores.Recall());
    summary << line;
  }
  std::printf("%s", summary.str().c_str());
  WriteTextAtomically((std::filesystem::path(out_dir) / "summary.txt").string(), summary.str());
  return 0;
}

}  // namespace

DYPHO_COMMAND("masks", "dynamic masks of a dataset's frames (mask and overlay PNGs)", RunMasks);

}  // namespace dypho::tools
