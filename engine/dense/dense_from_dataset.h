// The dense map of a finished run, rebuilt from its keyframes: the poses of
// keyframes.txt (TUM format, world_from_cam, as `dypho run` and `dypho map`
// write it) and the frames of the dataset with those timestamps (their
// depth, and the dataset's own dynamic masks when it has them: the run's
// computed masks are not saved, so on a dynamic sequence without mask files
// prefer the run's dense.ply). Used by `dypho export --points --keyframes`.
#pragma once

#include <string>

#include "engine/dense/dense_mapper.h"

namespace dypho {

struct DenseRebuildStats {
  int keyframes = 0;        // keyframes in keyframes.txt
  int used = 0;             // merged into the map
  int without_depth = 0;    // skipped: the frame has no depth image
  DenseMapStats dense;
};

// Throws InvalidInput naming the file and line when a keyframe's timestamp
// matches no frame of the dataset (within 1e-4 s), for unreadable files and
// bad options.
ColoredPoints DenseCloudFromKeyframes(const std::string& dataset_folder, const std::string& keyframes_path,
                                      const DenseMapOptions& options, DenseRebuildStats* stats = nullptr);

}  // namespace dypho
