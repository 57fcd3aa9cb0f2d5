// The outputs of `dypho run` after the map is finished (used by
// engine/pipeline/pipeline.cc): stage timings, trajectory accuracy, the
// independent map score (engine/eval/map_score.h) at every eval_every-th
// frame, keyframe renders, plots, report.md, scores.csv and metrics.json.
#pragma once

#include <chrono>
#include <map>
#include <string>
#include <vector>

#include "engine/api.h"
#include "engine/dataset/dataset.h"
#include "engine/pipeline/pipeline.h"
#include "engine/pipeline/pipeline_options.h"
#include "kernels/rasterizer.h"

namespace dypho {

// What the frame loop records of each frame.
struct FrameRecord {
  size_t index = 0;
  double timestamp = 0.0;
  bool has_pose = false;
  Rigid3d cam_from_world;
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();  // [rad/s] from this pose and the last frame's
  bool keyframe = false;
  StageTimings t;
  int backlog = 0;
  double mask_fraction = 0.0;
};

struct RunReportInputs {
  const PipelineOptions& options;
  const Dataset& dataset;
  const std::string& out_dir;
  const Camera& camera;                        // the dataset's (with distortion)
  const MaskingOptions& masking;               // as run
  const OrbTrackerOptions& tracker_options;    // as run
  const EngineOptions& engine_options;
  const std::vector<FrameRecord>& records;
  const std::vector<int>& keyframe_positions;  // positions in `records` of keyframe candidates
  const std::map<size_t, ImageU8>& eval_masks; // the run's final masks of the scored frames (dataset indices)
  const GaussianCloud& cloud;                  // the finished map
  const kernels::RasterSettings& raster;
  long total = 0;                              // frames planned
  std::chrono::steady_clock::time_point run_start;
};

// The dense map's counters into `result` (dense_* fields).
// Which mode ran, for the report: sequential, or threaded with the ages of
// its asynchronous inputs; realtime replay.
std::string RunMode(const PipelineOptions& options, const MaskingOptions& masking);

void SetDenseResult(const DenseMapStats& dense, PipelineResult* result);

// Each record with a pose takes the pose of the trajectory line with its
// timestamp (the final poses: loop closures and keyframe refinement
// included); records without such a line keep theirs.
void SetRecordPoses(const Trajectory& trajectory, std::vector<FrameRecord>* records);

// Fills the report fields of `result` and writes the files.
void WriteRunOutputs(const RunReportInputs& in, PipelineResult* result);

}  // namespace dypho
