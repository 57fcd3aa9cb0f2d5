// dypho synth: writes a synthetic dynamic RGB-D sequence in the TUM layout:
// the indoor room (--scene room) or the harbour (--scene shore).
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "common/check.h"
#include "engine/synth/shore/shore_scene.h"
#include "engine/synth/synthetic_scene.h"
#include "tools/command.h"
#include "tools/cli_checks.h"

namespace dypho::tools {
namespace {

int RunSynth(int argc, char** argv) {
  CLI::App app{
      "Write a synthetic dynamic RGB-D sequence (TUM layout: rgb/, depth/, masks/, rgb.txt,\n"
      "depth.txt, associations.txt, groundtruth.txt, camera.yaml) with exact poses, depth\n"
      "and dynamic masks. --scene shore: the synthetic harbour seen from a boat (water, sky,\n"
      "shore, pedestrians, a passing boat; 15 Hz, 320x240, 100 frames by default) with water/ and\n"
      "sky/ masks, optionally a stereo pair (stereo/).",
      "dypho synth"};
  SynthOptions options;
  std::string out_dir;
  std::string motion = SynthMotionName(options.motion);
  bool no_noise = false;
  std::string scene = "room";
  ShoreSynthOptions shore;
  bool no_boat = false;
  app.add_option("--scene", scene, "room (indoor, walkers) or shore (harbour seen from a boat)")
      ->capture_default_str()->check(CLI::IsMember({"room", "shore"}));
  app.add_option("--pedestrians", shore.num_pedestrians, "shore: people on the promenade, 0..6")
      ->capture_default_str();
  app.add_flag("--no-boat", no_boat, "shore: no passing boat");
  app.add_flag("--stereo", shore.stereo, "shore: also write a rectified stereo pair (12 cm baseline) in stereo/");
  app.add_option("--out", out_dir, "Output folder (created if needed)")->required()->check(NonEmptyPath());
  app.add_option("--frames", options.frames, "Number of frames")->capture_default_str();
  app.add_option("--walkers", options.num_walkers, "Moving people, 0..4")->capture_default_str();
  app.add_option("--motion", motion, "Camera motion: xyz, rpy, halfsphere, static or loop")->capture_default_str();
  app.add_option("--seed", options.seed, "Random seed (textures, walkers, noise)")->capture_default_str();
  app.add_option("--width", options.width, "Image width [px]")->capture_default_str();
  app.add_option("--height", options.height, "Image height [px]")->capture_default_str();
  app.add_option("--fps", options.fps, "Frame rate [Hz]")->capture_default_str();
  app.add_option("--max-coverage", options.max_coverage, "Largest fraction of an image the walkers may cover")
      ->capture_default_str();
  app.add_flag("--no-noise", no_noise, "Write exact depth (no Kinect noise, holes or range limits)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (scene == "shore") {
    // The room's defaults (640x480, 30 Hz, 120 frames) apply only when given.
    if (app.count("--frames")) shore.frames = options.frames;
    if (app.count("--seed")) shore.seed = options.seed;
    if (app.count("--width")) shore.width = options.width;
    if (app.count("--height")) shore.height = options.height;
    if (app.count("--fps")) shore.fps = options.fps;
    shore.boat = !no_boat;
    const ShoreSequenceSummary s = WriteShoreSequence(shore, out_dir);
    std::printf("wrote %d frames to %s in %.1f s (%.1f frames/s); water %.1f%%, sky %.1f%%, pedestrians and boat "
                "%.1f%% of an image (at most %.1f%%)\n",
                s.frames, out_dir.c_str(), s.seconds, s.frames / s.seconds, 100 * s.water_fraction,
                100 * s.sky_fraction, 100 * s.dynamic_fraction, 100 * s.max_dynamic_fraction);
    return 0;
  }
  DYPHO_CHECK_INPUT(ParseSynthMotion(motion, &options.motion))
      << "--motion must be xyz, rpy, halfsphere, static or loop (got '" << motion << "')";
  options.depth_noise = !no_noise;
  const SynthSequenceSummary summary = WriteSyntheticSequence(options, out_dir);
  std::printf(
      "wrote %d frames to %s in %.1f s (%.1f frames/s); walkers cover up to %.1f%% of an image "
      "(mean %.1f%%, %d frames with walkers)\n",
      summary.frames, out_dir.c_str(), summary.seconds, summary.frames / summary.seconds,
      100.0 * summary.max_coverage, 100.0 * summary.mean_coverage, summary.frames_with_walkers);
  return 0;
}

}  // namespace

DYPHO_COMMAND("synth", "write a synthetic dynamic RGB-D sequence (TUM layout, exact masks)", RunSynth);

}  // namespace dypho::tools
