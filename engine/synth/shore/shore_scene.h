// The synthetic harbour (`dypho synth --scene shore`; the shore preset's
// built-in sequence): a nearshore view from a slowly moving, gently rolling
// boat, rendered by the plain geometric renderer of the indoor generator
// (engine/synth/quad_renderer.h) plus analytic water and sky
// (engine/synth/shore/water_sky.h), with exact ground truth.
//
// Scene (engine/synth/shore/shore_layout.h): water (the plane z = 0, moving
// ripples, sky reflection and sun glints, different in every frame), sky
// with drifting clouds, the quay, a promenade with a railing, trees,
// buildings, a dock and bollards (textured boxes), pedestrians walking along
// the promenade behind the railing (engine/synth/walker.h) and a boat
// passing between the camera and the shore.
//
// Ground truth per frame: world_from_cam; depth = exact camera z of the
// shore, the pedestrians and the boat (0 on water and sky, as a stereo
// matcher would find, and beyond depth_max); per-class masks: water, sky
// and dynamic (pedestrians and the boat). Deterministic for a seed.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/eval/trajectory.h"
#include "engine/synth/shore/shore_options.h"
#include "engine/synth/synthetic_scene.h"

namespace dypho {

struct ShoreFrame {
  int index = 0;
  double timestamp = 0.0;  // [s]
  Rigid3d world_from_cam;  // ground truth (left camera)
  ImageU8 rgb;             // [H, W, 3]
  ImageF depth;            // exact camera z [m]; 0 on water, sky and beyond depth_max
  ImageU8 water;           // 255 = water
  ImageU8 sky;             // 255 = sky
  ImageU8 dynamic;         // 255 = a pedestrian or the boat
  ImageU8 right_rgb;       // the right camera (baseline along +x of the left one); empty unless stereo
};

// Class of a pixel in ShoreFrame's masks.
enum class ShoreClass { kShore, kWater, kSky, kDynamic };

class ShoreScene {
 public:
  // Throws InvalidInput naming the field for invalid options.
  explicit ShoreScene(const ShoreSynthOptions& options);
  ~ShoreScene();
  ShoreScene(const ShoreScene&) = delete;
  ShoreScene& operator=(const ShoreScene&) = delete;

  const ShoreSynthOptions& options() const;
  const Camera& camera() const;
  const Trajectory& trajectory() const;
  int num_frames() const;

  // Renders frame `frame_index` in [0, num_frames()). Thread-safe.
  ShoreFrame Render(int frame_index) const;
  // The static shore alone (no pedestrians, no boat) from any pose:
  // colour and depth as Render's wherever its dynamic mask is 0.
  SynthStaticView RenderStatic(const Rigid3d& world_from_cam, const Camera& camera, double t) const;

  // The static boxes (quay, buildings, trees, railing, dock, bollards).
  const std::vector<SynthBox>& static_boxes() const;
  // Pedestrians' body parts (walker k) and the boat's hull and cabin
  // (walker = num_pedestrians) at frame `frame_index`.
  std::vector<SynthBox> dynamic_boxes(int frame_index) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct ShoreSequenceSummary {
  int frames = 0;
  double water_fraction = 0.0;    // mean fraction of an image that is water
  double sky_fraction = 0.0;      // ... sky
  double dynamic_fraction = 0.0;  // ... pedestrians and the boat
  double max_dynamic_fraction = 0.0;
  double seconds = 0.0;           // wall time
};

// Writes the sequence in the TUM layout into `out_dir` (created if needed),
// as WriteSyntheticSequence does: rgb/, depth/ (16-bit, depth_factor per
// metre), masks/ (255 = dynamic: the layout the masking's dataset masks
// read), water/ and sky/ (255 = that class), rgb.txt, depth.txt,
// associations.txt, groundtruth.txt, camera.yaml, synth.yaml; with stereo
// also stereo/left/, stereo/right/, stereo/stereo.yaml and
// stereo/groundtruth.txt (the generic stereo layout, timestamps from 0).
// Every file is written atomically; the lists last.
ShoreSequenceSummary WriteShoreSequence(const ShoreSynthOptions& options, const std::string& out_dir);

}  // namespace dypho
