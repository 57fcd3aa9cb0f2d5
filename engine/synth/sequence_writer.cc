// WriteSyntheticSequence: renders every frame of a SyntheticScene and writes
// the TUM layout (see engine/synth/synthetic_scene.h).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "common/check.h"
#include "common/files.h"
#include "common/logging.h"
#include "common/progress.h"
#include "engine/eval/trajectory.h"
#include "engine/io/image_io.h"
#include "engine/synth/writer_text.h"
#include "engine/synth/synthetic_scene.h"

namespace dypho {
namespace {

using synth_text::Join;
using synth_text::Number;
using synth_text::TimestampName;

}  // namespace

SynthSequenceSummary WriteSyntheticSequence(const SynthOptions& options, const std::string& out_dir) {
  const auto start = std::chrono::steady_clock::now();
  DYPHO_CHECK_INPUT(!out_dir.empty()) << "synthetic sequence: output folder is empty";
  options.Validate();
  const SyntheticScene scene(options);
  for (const char* sub : {"rgb", "depth", "masks"}) MakeDirectories(Join(out_dir, sub));

  const int frames = scene.num_frames();
  std::vector<std::string> names(frames);
  for (int i = 0; i < frames; ++i) names[i] = TimestampName(scene.trajectory().timestamps[i]);
  std::vector<long> covered(frames, 0);

  Progress progress("synth " + out_dir, frames);
  std::exception_ptr error;
  std::atomic<bool> failed{false};
  // Frames in parallel (each frame renders on one thread); the output does
  // not depend on the order.
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < frames; ++i) {
    if (failed.load()) continue;
    try {
      const SynthFrame frame = scene.Render(i);
      const std::string file = names[i] + ".png";
      WriteRgb8(Join(out_dir, "rgb/" + file), frame.rgb);
      WriteDepth16(Join(out_dir, "depth/" + file), DepthToU16(frame.depth_noisy, options.depth_factor));
      WriteGray8(Join(out_dir, "masks/" + file), frame.mask);
      covered[i] = std::count(frame.mask.pixels().begin(), frame.mask.pixels().end(), uint8_t{255});
    } catch (...) {
#pragma omp critical(dypho_synth_error)
      {
        if (!error) error = std::current_exception();
      }
      failed.store(true);
    }
#pragma omp critical(dypho_synth_progress)
    progress.Advance();
  }
  if (error) std::rethrow_exception(error);

  // Lists last, so that a reader never sees a list of missing files.
  std::ostringstream rgb_txt, depth_txt, assoc_txt;
  const std::string about = "# dypho synthetic sequence: seed " + std::to_string(options.seed) + ", motion " +
                            SynthMotionName(options.motion) + ", " + std::to_string(options.num_walkers) +
                            " walker(s)\n";
  rgb_txt << "# color images\n" << about << "# timestamp filename\n";
  depth_txt << "# depth maps\n" << about << "# timestamp filename\n";
  for (int i = 0; i < frames; ++i) {
    rgb_txt << names[i] << " rgb/" << names[i] << ".png\n";
    depth_txt << names[i] << " depth/" << names[i] << ".png\n";
    assoc_txt << names[i] << " rgb/" << names[i] << ".png " << names[i] << " depth/" << names[i] << ".png\n";
  }
  WriteTextAtomically(Join(out_dir, "rgb.txt"), rgb_txt.str());
  WriteTextAtomically(Join(out_dir, "depth.txt"), depth_txt.str());
  WriteTextAtomically(Join(out_dir, "associations.txt"), assoc_txt.str());
  WriteTumTrajectory(Join(out_dir, "groundtruth.txt"), scene.trajectory());

  const Camera& camera = scene.camera();
  std::ostringstream yaml;
  yaml << "# Pinhole camera of a dypho synthetic sequence (OpenCV: x right, y down, z forward;\n"
       << "# pixel centres at integer coordinates). Depth PNG value / depth_factor = camera z [m].\n"
       << "fx: " << Number(camera.fx) << "\n"
       << "fy: " << Number(camera.fy) << "\n"
       << "cx: " << Number(camera.cx) << "\n"
       << "cy: " << Number(camera.cy) << "\n"
       << "width: " << camera.width << "\n"
       << "height: " << camera.height << "\n"
       << "depth_factor: " << Number(options.depth_factor) << "\n"
       << "distortion: [0, 0, 0, 0, 0]\n";
  WriteTextAtomically(Join(out_dir, "camera.yaml"), yaml.str());

  SynthSequenceSummary summary;
  summary.frames = frames;
  const double pixels = static_cast<double>(camera.width) * camera.height;
  for (int i = 0; i < frames; ++i) {
    const double c = covered[i] / pixels;
    summary.max_coverage = std::max(summary.max_coverage, c);
    summary.mean_coverage += c / frames;
    if (covered[i] > 0) ++summary.frames_with_walkers;
  }

  std::ostringstream info;
  info << "# How this sequence was made (dypho synth). World: metres, z up, floor at z = 0;\n"
       << "# groundtruth.txt holds world_from_cam; masks: 255 = walker.\n"
       << "generator: dypho synth\n"
       << "seed: " << options.seed << "\n"
       << "motion: " << SynthMotionName(options.motion) << "\n"
       << "frames: " << options.frames << "\n"
       << "fps: " << Number(options.fps) << "\n"
       << "start_time: " << Number(options.start_time) << "\n"
       << "num_walkers: " << options.num_walkers << "\n"
       << "walker_speed: " << Number(options.walker_speed) << "\n"
       << "max_coverage: " << Number(options.max_coverage) << "\n"
       << "depth_noise: " << (options.depth_noise ? "true" : "false") << "\n"
       << "depth_min: " << Number(options.depth_min) << "\n"
       << "depth_max: " << Number(options.depth_max) << "\n"
       << "depth_dropout: " << Number(options.depth_dropout) << "\n"
       << "walk_y_near: " << Number(scene.walk_y_near()) << "\n"
       << "coverage_max: " << Number(summary.max_coverage) << "\n"
       << "coverage_mean: " << Number(summary.mean_coverage) << "\n"
       << "frames_with_walkers: " << summary.frames_with_walkers << "\n";
  WriteTextAtomically(Join(out_dir, "synth.yaml"), info.str());

  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  progress.Finish("coverage max " + Number(std::round(summary.max_coverage * 1000) / 1000));
  return summary;
}

}  // namespace dypho
