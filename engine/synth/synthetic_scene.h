// Synthetic dynamic RGB-D sequences: the project's built-in default sequence
// and ground truth for the rasterizer, the tracker and the masking.
//
// A static room (floor, walls, ceiling, textured furniture) and one to four
// walkers (articulated box figures that cross the view, stop and turn),
// rendered by a plain geometric renderer (engine/synth/quad_renderer.h; not
// the Gaussian rasterizer) with exact depth and exact dynamic masks, plus a
// Kinect-like sensor depth. Deterministic for a seed: the same options give
// the same bytes for any thread count.
//
// Conventions
// - World: metres, z up (gravity along -z), floor at z = 0; the room spans
//   x in [-3, 3], y in [-2.5, 3.5], z in [0, 2.7]; cameras look towards +y.
// - Camera: OpenCV pinhole, x right, y down, z forward; poses are
//   world_from_cam (the camera centre is the translation).
// - Depth: camera z [m] (not range along the ray), 0 = no measurement.
// - Mask: 255 where the pixel centre's nearest surface is a walker, else 0.
// - The layout of the room is fixed; textures, walker paths, walker looks and
//   the depth noise change with the seed. The camera path depends only on the
//   seed, the preset and the time. Walker paths are moved away from the
//   camera, as a whole, until no frame exceeds max_coverage, so they can
//   differ between a short sequence and a longer one with the same seed.
//   They do not depend on the image size (coverage is planned at 320 px
//   width, with a margin of 0.015).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/eval/trajectory.h"
#include "engine/synth/synth_options.h"

namespace dypho {

struct SynthFrame {
  int index = 0;           // frame number
  double timestamp = 0.0;  // [s]
  Rigid3d world_from_cam;  // ground-truth pose
  ImageU8 rgb;             // [H, W, 3]
  ImageF depth;            // exact camera z [m]
  ImageF depth_noisy;      // sensor depth [m], 0 = hole, quantised; equals `depth` when noise is off
  ImageU8 mask;            // 255 = walker, 0 = static scene
};

// The static scene alone (no walkers) seen from some pose.
struct SynthStaticView {
  ImageU8 rgb;   // [H, W, 3]
  ImageF depth;  // exact camera z [m]; 0 where nothing is hit (outside the room)
};

// A box of the scene (furniture or a walker's body part).
struct SynthBox {
  Rigid3d world_from_box;  // centre and orientation
  Eigen::Vector3d size;    // edge lengths along the box axes [m]
  int walker = -1;         // -1 = static, k = part of walker k
};

class SyntheticScene {
 public:
  // Builds textures, the trajectory and the walkers' paths. Throws
  // InvalidInput naming the field for invalid options, or naming
  // max_coverage when the walkers cannot be kept under it.
  explicit SyntheticScene(const SynthOptions& options);
  ~SyntheticScene();
  SyntheticScene(const SyntheticScene&) = delete;
  SyntheticScene& operator=(const SyntheticScene&) = delete;

  const SynthOptions& options() const;
  const Camera& camera() const;
  const Trajectory& trajectory() const;
  int num_frames() const;

  // Renders frame `frame_index` in [0, num_frames()). Thread-safe.
  SynthFrame Render(int frame_index) const;
  // The static scene (no walkers) from any pose and undistorted camera:
  // bit-identical to Render's colour and depth wherever its mask is 0.
  SynthStaticView RenderStatic(const Rigid3d& world_from_cam, const Camera& camera) const;

  // The room's interior [m].
  Eigen::AlignedBox3d room() const;
  // The furniture boxes (the room's walls are not included).
  const std::vector<SynthBox>& static_boxes() const;
  // The walkers' body parts at frame `frame_index`.
  std::vector<SynthBox> walker_boxes(int frame_index) const;
  // World y of the near edge of the walkers' area [m]; moved away from the
  // camera during construction until max_coverage holds.
  double walk_y_near() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct SynthSequenceSummary {
  int frames = 0;               // frames written
  double max_coverage = 0.0;    // largest fraction of an image covered by walkers
  double mean_coverage = 0.0;   // average fraction over frames
  int frames_with_walkers = 0;  // frames whose mask is not empty
  double seconds = 0.0;         // wall time
};

// Writes a sequence in the TUM layout into `out_dir` (created if needed):
//   rgb/<t>.png, depth/<t>.png (16-bit, depth_factor units per metre; the
//   sensor depth), masks/<t>.png (255 = walker), rgb.txt, depth.txt,
//   associations.txt, groundtruth.txt (world_from_cam), camera.yaml
//   (fx fy cx cy width height depth_factor distortion) and synth.yaml (the
//   options). <t> is the timestamp with 6 decimals. Every file is written
//   atomically; the list files are written last. Files of an earlier
//   sequence in the same folder are overwritten, not deleted.
SynthSequenceSummary WriteSyntheticSequence(const SynthOptions& options, const std::string& out_dir);

}  // namespace dypho
