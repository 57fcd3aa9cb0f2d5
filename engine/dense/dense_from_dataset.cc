#include "engine/dense/dense_from_dataset.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/trajectory.h"
#include "engine/map/undistort.h"

namespace dypho {

ColoredPoints DenseCloudFromKeyframes(const std::string& dataset_folder, const std::string& keyframes_path,
                                      const DenseMapOptions& options, DenseRebuildStats* stats) {
  options.Validate();
  const Trajectory keyframes = ReadTumTrajectory(keyframes_path);
  DYPHO_CHECK_INPUT(!keyframes.timestamps.empty()) << keyframes_path << ": no keyframe";
  const auto dataset = OpenDataset(dataset_folder);
  const Undistorter undistort(dataset->camera());
  DenseMapper dense(undistort.pinhole(), options, false);
  DenseRebuildStats s;
  s.keyframes = static_cast<int>(keyframes.timestamps.size());
  const std::vector<FrameInfo>& frames = dataset->frames();
  for (size_t k = 0; k < keyframes.timestamps.size(); ++k) {
    const double t = keyframes.timestamps[k];
    // Frames are in time order: the nearest RGB timestamp.
    const auto it = std::lower_bound(frames.begin(), frames.end(), t,
                                     [](const FrameInfo& f, double v) { return f.timestamp < v; });
    const FrameInfo* best = nullptr;
    for (auto c : {it, it == frames.begin() ? it : it - 1}) {
      if (c == frames.end()) continue;
      if (best == nullptr || std::abs(c->timestamp - t) < std::abs(best->timestamp - t)) best = &*c;
    }
    DYPHO_CHECK_INPUT(best != nullptr && std::abs(best->timestamp - t) < 1e-4)
        << keyframes_path << ": keyframe " << k << " (line " << k + 1 << " of the poses, t=" << t
        << ") matches no frame of " << dataset_folder;
    if (!best->has_depth) {
      ++s.without_depth;
      continue;
    }
    const Frame frame = dataset->Load(best->index);
    KeyframeInput in;
    in.timestamp = frame.timestamp;
    in.rgb = undistort.Rgb(frame.rgb);
    in.depth = undistort.Depth(frame.depth);
    in.dynamic_mask = undistort.ExcludedPixels(frame.dynamic_mask);  // undistorts the mask itself
    in.cam_from_world = keyframes.world_from_cam[k].Inverse();
    dense.Add(static_cast<int>(k), std::move(in));
    ++s.used;
  }
  ColoredPoints cloud = dense.Cloud();
  s.dense = dense.stats();
  if (stats != nullptr) *stats = s;
  return cloud;
}

}  // namespace dypho
