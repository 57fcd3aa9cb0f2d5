// A dataset's summary for `dypho dataset-info`: frames, camera, depth and
// ground-truth coverage, optionally from decoding every frame.
#pragma once

#include <cstddef>
#include <string>

#include "engine/dataset/dataset.h"

namespace dypho {

// What decoding every frame found.
struct DatasetScan {
  size_t frames_loaded = 0;            // frames decoded
  size_t depth_frames = 0;             // frames with a depth image
  double mean_valid_depth = 0.0;       // mean fraction of pixels with valid depth (over depth frames)
  double min_valid_depth = 0.0;        // smallest per-frame fraction of valid depth pixels
  double min_depth = 0.0;              // [m] smallest valid depth seen
  double max_depth = 0.0;              // [m] largest valid depth seen
  size_t mask_frames = 0;              // frames with a dynamic mask
  double mean_dynamic_fraction = 0.0;  // mean fraction of dynamic pixels (over mask frames)
  double seconds = 0.0;                // [s] time spent decoding
};

// Decodes every frame (reporting progress: frames done, rate, time left).
// Throws InvalidInput at the first bad frame.
DatasetScan ScanDataset(const Dataset& dataset, bool show_progress = true);

// Human-readable summary; includes the scan's figures when `scan` is given.
std::string DescribeDataset(const Dataset& dataset, const DatasetScan* scan = nullptr);

}  // namespace dypho
