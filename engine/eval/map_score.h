// The independent score of a Gaussian map against real frames: what a user
// runs to see how good an exported map is (`dypho score`), and what the
// reports of `dypho run` and `dypho map` use.
//
// For every `every`-th frame of the dataset that the trajectory covers:
//  1. The frame is undistorted to the ideal pinhole camera (the map's
//     camera); when the trajectory covers the depth image's own timestamp,
//     the depth is moved to the colour image's pose (engine/map/depth_warp.h).
//  2. The map is rendered there (depth-sorted, global shutter, no colour
//     response): the plain render a viewer shows.
//  3. Scored pixels: the whole image except the undistortion border (pixels
//     without image data) and, with `exclude_dataset_masks`, the dataset's
//     dynamic masks. PSNR and SSIM (engine/eval/image_metrics.h) of the
//     render clamped to [0, 1]; depth L1 [m] where the frame has a depth
//     (inside [min_depth, max_depth] when set) and the render's alpha exceeds 0.5; coverage = fraction of scored pixels
//     with alpha > 0.5 (holes in the map lower it and the PSNR).
//  4. Colour-aligned (reported separately, never mixed into the plain
//     figures): per channel the affine map real ~ a * render + b that
//     minimises the squared error over the scored pixels, then PSNR/SSIM.
//     This removes the camera's automatic exposure and white balance.
// Frames whose timestamp matches a keyframe (within 1 ms) are marked
// `trained`; the summary gives the means over all scored frames and over
// the untrained ones (novel views).
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "engine/dataset/dataset.h"
#include "engine/eval/trajectory.h"
#include "engine/gaussians.h"
#include "engine/map/sensor_model.h"

namespace dypho {

struct MapScoreOptions {
  int every = 10;                    // score every n-th dataset frame (index % every == 0)
  size_t first_frame = 0;            // first dataset frame considered
  size_t max_frames = 0;             // dataset frames considered from first_frame (0 = all)
  double max_gap = 0.1;              // [s] largest trajectory gap interpolated across
  bool exclude_dataset_masks = true; // leave the dataset's dynamic masks (masks/) out of the score
  bool retime_depth = true;          // move the depth image to the colour image's timestamp
  float background = 0.0f;           // background grey level of the renders [0, 1]
  int num_threads = 0;               // rasterizer threads (0 = all)
  int eval_downscale = 1;            // score at 1/n resolution (1 = full)
  // Reference depths outside [min_depth, max_depth] are not scored (the
  // range the map is built from: a stereo depth of the sky at 300 m is no
  // error of a map kept to 25 m). max_depth 0 = no limit.
  float min_depth = 0.0f, max_depth = 0.0f;  // [m]
  std::vector<double> trained_timestamps;  // [s] keyframe timestamps (frames the map was trained on)
  // Dynamic masks (camera size, as the dataset's; non-zero = dynamic) for
  // frames the dataset has no mask for, e.g. the masks a run computed.
  std::map<size_t, ImageU8> fallback_masks;
  // When active, a third figure: the render passed through the camera's
  // rolling shutter and motion blur (engine/map/sensor_model.h), with the
  // angular velocity from the trajectory (+-10 ms). Reported apart.
  SensorModel sensor;
  void Validate() const;             // throws InvalidInput naming the field
};

struct FrameMapScore {
  size_t frame = 0;              // dataset index
  double timestamp = 0.0;        // [s]
  bool trained = false;          // a keyframe of the map
  double psnr = 0.0;             // [dB] plain render
  double ssim = 0.0;             // plain render
  double depth_l1 = 0.0;         // [m]; NaN without depth
  double coverage = 0.0;         // fraction of scored pixels with alpha > 0.5
  double psnr_aligned = 0.0;     // [dB] after the per-frame affine colour alignment
  double ssim_aligned = 0.0;
  double psnr_sensor = 0.0;      // [dB] through the sensor model (NaN when it is off)
};

struct MapScoreSummary {
  int frames = 0;
  double psnr = 0.0, ssim = 0.0, depth_l1 = 0.0, coverage = 0.0;  // means (depth over frames with depth)
  double psnr_aligned = 0.0, ssim_aligned = 0.0;
  double psnr_sensor = 0.0;      // NaN when the sensor model is off
  double worst_psnr = 0.0;       // [dB] lowest plain PSNR
  size_t worst_frame = 0;        // its dataset index
};

struct MapScore {
  std::vector<FrameMapScore> frames;  // in dataset order
  MapScoreSummary all;                // every scored frame
  MapScoreSummary untrained;          // frames that are not keyframes (frames == 0 when there are none)
  std::vector<size_t> uncovered;      // frames every-th that the trajectory does not cover
};

// Called after each scored frame with (done, planned).
using MapScoreProgress = std::function<void(size_t, size_t)>;
// Called for each scored frame with its score, the plain render and the
// undistorted real frame (8-bit RGB, scoring resolution), e.g. for pictures.
using MapScoreVisitor = std::function<void(const FrameMapScore&, const ImageU8& rendered, const ImageU8& real)>;

// Scores `cloud` (world frame of `world_from_cam`) against `dataset`.
// Throws InvalidInput for an empty map, bad options, or a trajectory that
// covers none of the chosen frames.
MapScore ScoreMap(const GaussianCloud& cloud, const Dataset& dataset, const Trajectory& world_from_cam,
                  const MapScoreOptions& options = MapScoreOptions(), const MapScoreProgress& progress = {},
                  const MapScoreVisitor& visit = {});

// Summary over a subset (used for `all` and `untrained`).
MapScoreSummary Summarize(const std::vector<FrameMapScore>& frames);

// scores.csv: one line per scored frame, with a header.
std::string FormatMapScoreCsv(const MapScore& score);
// A short Markdown table of both summaries.
std::string FormatMapScoreTable(const MapScore& score);

}  // namespace dypho
