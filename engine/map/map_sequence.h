// Mapping a recorded RGB-D sequence with known or tracked poses: keyframe
// selection, undistortion, the Mapper, and evaluation of the map on the
// keyframes and on held-out frames. Used by `dypho map`, the tests and the
// benchmark; the whole system (`dypho run`) adds masking and threads.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/rigid3.h"
#include "engine/dataset/dataset.h"
#include "engine/dense/dense_mapper.h"
#include "engine/eval/trajectory.h"
#include "engine/map/keyframe_selector.h"
#include "engine/map/mapper.h"

namespace dypho {

class Tracker;

// Where poses come from. kGroundTruth: the dataset's (interpolated) ground
// truth; kTrajectory: a TUM trajectory file (world_from_cam, interpolated at
// frame timestamps); kTracker: a Tracker (e.g. the ORB tracker).
struct PoseSource {
  enum class Kind { kGroundTruth, kTrajectory, kTracker } kind = Kind::kGroundTruth;
  Trajectory trajectory;             // kTrajectory
  std::string trajectory_path;       // for messages
  Tracker* tracker = nullptr;        // kTracker (not owned)
  double max_gap = 0.5;              // [s] largest trajectory gap interpolated across
};

struct SequenceMappingOptions {
  MapperOptions mapper;
  KeyframePolicy keyframes;
  int iterations_per_keyframe = 40;  // optimisation steps after each keyframe
  int final_iterations = 300;        // steps over all keyframes at the end
  int carve_votes = 2;               // before them, Mapper::CarveFreeSpace with this many votes (0 = off)
  DenseMapOptions dense;             // the static dense point cloud of the keyframes (dense.ply)
  size_t first_frame = 0;            // first frame used
  size_t max_frames = 0;             // 0 = to the end
  size_t frame_step = 1;             // use every n-th frame
  int heldout_every = 5;             // evaluate every n-th non-keyframe frame (0 = none)
  bool use_dataset_masks = true;     // dynamic masks from the dataset's masks/ folder
  // Move each depth image to its colour image's pose when their timestamps
  // differ by more than 1 ms (engine/map/depth_warp.h), with the pose source
  // at the depth timestamp (the tracker: interpolation between frames).
  bool retime_depth = true;
  bool evaluate = true;              // PSNR/SSIM/depth on keyframes and held-out frames
  // Held-out frames are aligned to the map first (Mapper::AlignFrame: pose
  // and colour response, this many steps; 0 = scored at their given pose
  // with the map's colours). Needed when keyframe poses or exposures are
  // refined: the map then no longer sits exactly at the given poses' frame.
  int align_heldout_iterations = 0;
  int eval_downscale = 1;            // evaluate at 1/n resolution (1 = full)
  // A frame that cannot be read (truncated image, wrong size) is skipped
  // with a warning and counted; with `strict`, mapping stops there instead
  // and the map of the frames before it is finished and returned, with
  // SequenceMappingResult::stopped_at saying why.
  bool strict = false;
  void Validate() const;
};

struct FrameScore {
  size_t frame = 0;         // dataset index
  double timestamp = 0.0;   // [s]
  double psnr = 0.0;        // [dB] on static pixels
  double ssim = 0.0;        // on static pixels
  double depth_l1 = 0.0;    // [m] on static pixels with valid depth and rendered alpha > 0.5
  // [dB] the plain render at the frame's given pose (no sensor model, colour
  // response or alignment) against the frame.
  double psnr_raw = 0.0;
};

struct SequenceMappingResult {
  std::vector<size_t> keyframe_frames;  // dataset indices of the keyframes
  Trajectory trajectory;                // world_from_cam of every frame with a pose
  std::vector<size_t> frames_without_pose;
  std::vector<size_t> unreadable_frames;  // skipped because they could not be read
  std::string stopped_at;                 // with options.strict: the read error that ended mapping
  std::vector<FrameScore> keyframe_scores;  // with the final map
  std::vector<FrameScore> heldout_scores;   // frames never trained on
  std::vector<double> loss_history;         // mean loss of each Optimize call, in order
  double loss_before_final = 0.0;           // loss over all keyframes before the final refinement
  double loss_after_final = 0.0;            // ... and after it
  MapperStats stats;
  ColoredPoints dense_cloud;   // the dense map at the final keyframe poses (with options.dense.enabled)
  DenseMapStats dense_stats;
  double seconds = 0.0;            // wall time of mapping (loading included, evaluation excluded)
  double eval_seconds = 0.0;
  size_t peak_rss_bytes = 0;
  double MeanPsnr(bool heldout) const;
  double MeanPsnrRaw(bool heldout) const;
  double MeanSsim(bool heldout) const;
  double MeanDepthL1(bool heldout) const;
};

// Progress callback: (frames done, frames total, message).
using MappingProgress = std::function<void(size_t, size_t, const std::string&)>;

// Maps the dataset. `mapper_out` (optional) receives the mapper so the caller
// can render, export or continue. Throws InvalidInput for bad options, a
// pose source that cannot serve the dataset (no ground truth), or bad frames.
SequenceMappingResult MapSequence(const Dataset& dataset, const PoseSource& poses,
                                  const SequenceMappingOptions& options,
                                  std::unique_ptr<Mapper>* mapper_out = nullptr,
                                  const MappingProgress& progress = nullptr);

// Scores a render against a frame: static pixels (mask 0) only.
FrameScore ScoreView(const RenderedView& view, const ImageU8& rgb, const ImageF& depth, const ImageU8& dynamic_mask);

// Peak resident set size of this process [bytes] (0 when unknown).
size_t PeakRssBytes();

}  // namespace dypho
