// WriteShoreSequence: renders every frame of a ShoreScene and writes the TUM
// layout plus per-class masks (and the generic stereo layout with stereo).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "common/check.h"
#include "common/files.h"
#include "common/progress.h"
#include "engine/eval/trajectory.h"
#include "engine/io/image_io.h"
#include "engine/synth/writer_text.h"
#include "engine/synth/shore/shore_scene.h"

namespace dypho {
namespace {

using synth_text::Join;
using synth_text::Number;
using synth_text::TimestampName;

long Count255(const ImageU8& mask) { return std::count(mask.pixels().begin(), mask.pixels().end(), uint8_t{255}); }

void WriteStereoYaml(const std::string& path, const Camera& camera, const ShoreSynthOptions& options) {
  std::ostringstream y;
  auto cam = [&](const char* key) {
    y << key << ":\n  fx: " << Number(camera.fx) << "\n  fy: " << Number(camera.fy) << "\n  cx: "
      << Number(camera.cx) << "\n  cy: " << Number(camera.cy) << "\n";
  };
  y << "# Rectified stereo pair of the dypho synthetic harbour (right camera at +baseline along x).\n"
    << "width: " << camera.width << "\nheight: " << camera.height << "\nframe_rate: " << Number(options.fps) << "\n";
  cam("left");
  cam("right");
  y << "right_from_left:\n  rotation: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n  translation: [" << Number(-options.baseline)
    << ", 0, 0]\n";
  WriteTextAtomically(path, y.str());
}

}  // namespace

ShoreSequenceSummary WriteShoreSequence(const ShoreSynthOptions& options, const std::string& out_dir) {
  const auto start = std::chrono::steady_clock::now();
  DYPHO_CHECK_INPUT(!out_dir.empty()) << "shore sequence: output folder is empty";
  options.Validate();
  const ShoreScene scene(options);
  for (const char* sub : {"rgb", "depth", "masks", "water", "sky"}) MakeDirectories(Join(out_dir, sub));
  if (options.stereo) {
    for (const char* sub : {"stereo/left", "stereo/right"}) MakeDirectories(Join(out_dir, sub));
  }
  const int frames = scene.num_frames();
  std::vector<std::string> names(frames);
  for (int i = 0; i < frames; ++i) names[i] = TimestampName(scene.trajectory().timestamps[i]);
  std::vector<long> water(frames, 0), sky(frames, 0), dynamic(frames, 0);

  Progress progress("synth shore " + out_dir, frames);
  std::exception_ptr error;
  std::atomic<bool> failed{false};
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < frames; ++i) {
    if (failed.load()) continue;
    try {
      const ShoreFrame frame = scene.Render(i);
      const std::string file = names[i] + ".png";
      WriteRgb8(Join(out_dir, "rgb/" + file), frame.rgb);
      WriteDepth16(Join(out_dir, "depth/" + file), DepthToU16(frame.depth, options.depth_factor));
      WriteGray8(Join(out_dir, "masks/" + file), frame.dynamic);
      WriteGray8(Join(out_dir, "water/" + file), frame.water);
      WriteGray8(Join(out_dir, "sky/" + file), frame.sky);
      if (options.stereo) {
        char stereo_name[32];
        std::snprintf(stereo_name, sizeof(stereo_name), "%06d.png", i);
        WriteRgb8(Join(out_dir, std::string("stereo/left/") + stereo_name), frame.rgb);
        WriteRgb8(Join(out_dir, std::string("stereo/right/") + stereo_name), frame.right_rgb);
      }
      water[i] = Count255(frame.water);
      sky[i] = Count255(frame.sky);
      dynamic[i] = Count255(frame.dynamic);
    } catch (...) {
#pragma omp critical(dypho_shore_error)
      {
        if (!error) error = std::current_exception();
      }
      failed.store(true);
    }
#pragma omp critical(dypho_shore_progress)
    progress.Advance();
  }
  if (error) std::rethrow_exception(error);

  std::ostringstream rgb_txt, depth_txt, assoc_txt;
  const std::string about = "# dypho synthetic harbour: seed " + std::to_string(options.seed) + ", " +
                            std::to_string(options.num_pedestrians) + " pedestrian(s), boat " +
                            (options.boat ? "yes" : "no") + "\n";
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
  if (options.stereo) {
    Trajectory from_zero;
    for (int i = 0; i < frames; ++i) from_zero.Add(i / options.fps, scene.trajectory().world_from_cam[i]);
    WriteTumTrajectory(Join(out_dir, "stereo/groundtruth.txt"), from_zero);
    WriteStereoYaml(Join(out_dir, "stereo/stereo.yaml"), camera, options);
  }

  std::ostringstream yaml;
  yaml << "# Pinhole camera of the dypho synthetic harbour (OpenCV: x right, y down, z forward;\n"
       << "# pixel centres at integer coordinates). Depth PNG value / depth_factor = camera z [m].\n"
       << "fx: " << Number(camera.fx) << "\nfy: " << Number(camera.fy) << "\ncx: " << Number(camera.cx)
       << "\ncy: " << Number(camera.cy) << "\nwidth: " << camera.width << "\nheight: " << camera.height
       << "\ndepth_factor: " << Number(options.depth_factor) << "\ndistortion: [0, 0, 0, 0, 0]\n";
  WriteTextAtomically(Join(out_dir, "camera.yaml"), yaml.str());

  ShoreSequenceSummary summary;
  summary.frames = frames;
  const double pixels = static_cast<double>(camera.width) * camera.height;
  for (int i = 0; i < frames; ++i) {
    summary.water_fraction += water[i] / pixels / frames;
    summary.sky_fraction += sky[i] / pixels / frames;
    summary.dynamic_fraction += dynamic[i] / pixels / frames;
    summary.max_dynamic_fraction = std::max(summary.max_dynamic_fraction, dynamic[i] / pixels);
  }
  std::ostringstream info;
  info << "# How this sequence was made (dypho synth --scene shore). World: metres, z up, water at z = 0;\n"
       << "# groundtruth.txt holds world_from_cam; masks/: 255 = pedestrian or boat; water/, sky/: 255 = that class.\n"
       << "generator: dypho synth\nscene: shore\nseed: " << options.seed << "\nframes: " << options.frames
       << "\nfps: " << Number(options.fps) << "\nstart_time: " << Number(options.start_time)
       << "\nnum_pedestrians: " << options.num_pedestrians << "\nboat: " << (options.boat ? "true" : "false")
       << "\nboat_speed: " << Number(options.boat_speed) << "\nboat_speed_own: " << Number(options.boat_speed_own)
       << "\nroll_deg: " << Number(options.roll_deg) << "\ndepth_max: " << Number(options.depth_max)
       << "\nstereo: " << (options.stereo ? "true" : "false") << "\nbaseline: " << Number(options.baseline)
       << "\nwater_fraction: " << Number(summary.water_fraction) << "\nsky_fraction: " << Number(summary.sky_fraction)
       << "\ndynamic_fraction: " << Number(summary.dynamic_fraction) << "\n";
  WriteTextAtomically(Join(out_dir, "synth.yaml"), info.str());
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  progress.Finish("water " + Number(std::round(summary.water_fraction * 100) / 100));
  return summary;
}

}  // namespace dypho
