// A program outside the dypho tree that uses the installed package
// (find_package(dypho)) as its mapping backend, through the embedding API
// (engine/api.h): it feeds a synthetic RGB-D sequence with known poses as
// plain buffers, corrects one keyframe pose as a host's loop closure would,
// renders a view that was never a keyframe, and saves the map.
// Exits non-zero when the render does not match the real frame.
#include <cmath>
#include <cstdio>
#include <string>

#include "engine/api.h"
#include "engine/eval/image_metrics.h"
#include "engine/io/image_io.h"
#include "engine/synth/synthetic_scene.h"

int main(int argc, char** argv) {
  const std::string out_dir = argc > 1 ? argv[1] : "dypho_consumer_out";
  dypho::SynthOptions synth;
  synth.width = 160;
  synth.height = 120;
  synth.frames = 24;
  synth.num_walkers = 1;
  synth.depth_noise = false;
  const dypho::SyntheticScene scene(synth);

  dypho::EngineOptions options;
  options.camera = scene.camera();
  options.mapper.train_downscale = 1;
  options.mapper.sh_degree = 0;
  options.iterations_per_keyframe = 20;
  options.final_iterations = 60;
  options.keyframes.max_frame_gap = 4;
  // Keyframes wait in a bounded queue while the mapping thread works; when it
  // is full the oldest waiting one is dropped (EngineStatus counts them). A
  // host sizes it to the latency it accepts; here every keyframe fits.
  options.queue_capacity = 64;
  auto engine = dypho::Engine::Create(options);

  for (int i = 0; i < scene.num_frames(); ++i) {
    const dypho::SynthFrame f = scene.Render(i);
    dypho::FrameBuffers buffers;
    buffers.timestamp = f.timestamp;
    buffers.rgb = f.rgb.data();
    buffers.depth_m = f.depth_noisy.data();
    buffers.dynamic_mask = f.mask.data();  // the walker stays out of the map
    const dypho::Rigid3d cam_from_world = f.world_from_cam.Inverse();
    engine->PushFrame(buffers, &cam_from_world);
  }
  // A host's loop closure re-asserting keyframe 1's pose (unchanged here).
  engine->UpdateKeyframePose(1, engine->KeyframePose(1));
  engine->Finish();

  const dypho::SynthFrame probe = scene.Render(scene.num_frames() / 2 + 1);
  const dypho::EngineRender render = engine->Render(scene.camera(), probe.world_from_cam.Inverse());
  dypho::ImageF color(render.width, render.height, 3);
  for (size_t i = 0; i < color.size(); ++i) color.data()[i] = std::fmin(1.0f, std::fmax(0.0f, render.color[i]));
  dypho::ImageU8 include(render.width, render.height, 1);
  for (size_t i = 0; i < include.size(); ++i) include.data()[i] = probe.mask.data()[i] ? 0 : 255;
  const double psnr = dypho::Psnr(color, dypho::ToFloat(probe.rgb), include);
  engine->Save(out_dir);
  const dypho::EngineStatus status = engine->Status();
  std::printf("dypho consumer: %d frames, %d keyframes, %d Gaussians, held-out PSNR %.2f dB, map in %s/map.ply\n",
              status.frames, status.mapped_keyframes, status.num_gaussians, psnr, out_dir.c_str());
  return psnr > 20.0 ? 0 : 1;
}
