#include "engine/dataset/dataset_info.h"

#include "engine/stereo/rig.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "common/progress.h"

namespace dypho {
namespace {

std::string Fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

// "0-3, 7, 9-12" for a sorted list of indices.
std::string Ranges(const std::vector<size_t>& indices, size_t max_ranges = 8) {
  std::string out;
  size_t ranges = 0;
  for (size_t i = 0; i < indices.size();) {
    size_t j = i;
    while (j + 1 < indices.size() && indices[j + 1] == indices[j] + 1) ++j;
    if (ranges == max_ranges) {
      out += ", ...";
      break;
    }
    out += (out.empty() ? "" : ", ") + std::to_string(indices[i]);
    if (j > i) out += "-" + std::to_string(indices[j]);
    ++ranges;
    i = j + 1;
  }
  return out;
}

}  // namespace

DatasetScan ScanDataset(const Dataset& dataset, bool show_progress) {
  DatasetScan scan;
  const auto start = std::chrono::steady_clock::now();
  Progress progress("dataset-info " + dataset.name(), static_cast<long>(dataset.size()),
                    show_progress ? 1.0 : std::numeric_limits<double>::infinity());
  double valid_sum = 0.0, dynamic_sum = 0.0;
  scan.min_valid_depth = 1.0;
  scan.min_depth = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < dataset.size(); ++i) {
    const Frame frame = dataset.Load(i);
    ++scan.frames_loaded;
    if (frame.has_depth) {
      ++scan.depth_frames;
      size_t valid = 0;
      for (float d : frame.depth.pixels()) {
        if (d > 0 && std::isfinite(d)) {
          ++valid;
          scan.min_depth = std::min<double>(scan.min_depth, d);
          scan.max_depth = std::max<double>(scan.max_depth, d);
        }
      }
      const double fraction = static_cast<double>(valid) / std::max<size_t>(1, frame.depth.size());
      valid_sum += fraction;
      scan.min_valid_depth = std::min(scan.min_valid_depth, fraction);
    }
    if (!frame.dynamic_mask.empty()) {
      ++scan.mask_frames;
      const size_t dynamic =
          std::count_if(frame.dynamic_mask.pixels().begin(), frame.dynamic_mask.pixels().end(),
                        [](uint8_t v) { return v != 0; });
      dynamic_sum += static_cast<double>(dynamic) / std::max<size_t>(1, frame.dynamic_mask.size());
    }
    progress.Advance(1);
  }
  if (show_progress) progress.Finish();
  if (scan.depth_frames > 0) {
    scan.mean_valid_depth = valid_sum / scan.depth_frames;
  } else {
    scan.min_valid_depth = 0.0;
  }
  if (!std::isfinite(scan.min_depth)) scan.min_depth = 0.0;
  if (scan.mask_frames > 0) scan.mean_dynamic_fraction = dynamic_sum / scan.mask_frames;
  scan.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return scan;
}

std::string DescribeDataset(const Dataset& dataset, const DatasetScan* scan) {
  std::ostringstream s;
  const Camera& c = dataset.camera();
  s << "dataset      " << dataset.name() << " (" << dataset.format() << ") at " << dataset.folder() << "\n";
  s << "frames       " << dataset.size();
  if (dataset.size() > 0) {
    const double t0 = dataset.frames().front().timestamp, t1 = dataset.frames().back().timestamp;
    s << ", " << Fixed(t1 - t0, 3) << " s";
    if (dataset.size() > 1 && t1 > t0) s << ", " << Fixed((dataset.size() - 1) / (t1 - t0), 2) << " Hz";
    s << " (t = " << Fixed(t0, 6) << " .. " << Fixed(t1, 6) << ")";
  }
  s << "\n";
  s << "camera       " << c.width << "x" << c.height << " fx " << c.fx << " fy " << c.fy << " cx " << c.cx
    << " cy " << c.cy;
  if (c.HasDistortion()) {
    s << " distortion";
    for (double d : c.distortion) s << " " << d;
  }
  s << "\n             from " << dataset.camera_source() << "\n";
  s << "depth        " << dataset.frames_with_depth() << " of " << dataset.size() << " frames, ";
  if (dataset.stereo())
    s << "from stereo disparity (" << stereo::DisparityMethodName(dataset.stereo()->disparity.method)
      << ", baseline " << dataset.stereo()->baseline << " m" << (dataset.stereo()->rectify ? ", rectified here" : "")
      << ")";
  else
    s << "factor " << dataset.depth_factor() << " per metre";
  std::vector<size_t> no_depth;
  for (const FrameInfo& f : dataset.frames()) {
    if (!f.has_depth) no_depth.push_back(f.index);
  }
  if (!no_depth.empty()) s << "; without depth: frames " << Ranges(no_depth);
  s << "\n";
  if (!dataset.stereo() && dataset.frames_with_depth() > 0)
    s << "             captured at: " << dataset.depth_time_source() << "\n";
  if (scan != nullptr && scan->depth_frames > 0) {
    s << "             valid depth pixels " << Fixed(100.0 * scan->mean_valid_depth, 1)
      << "% on average (min " << Fixed(100.0 * scan->min_valid_depth, 1) << "%), range "
      << Fixed(scan->min_depth, 3) << " .. " << Fixed(scan->max_depth, 3) << " m\n";
  }
  s << "masks        " << dataset.frames_with_mask() << " of " << dataset.size() << " frames";
  if (scan != nullptr && scan->mask_frames > 0) {
    s << ", " << Fixed(100.0 * scan->mean_dynamic_fraction, 2) << "% dynamic pixels on average";
  }
  s << "\n";
  if (dataset.has_ground_truth()) {
    const Trajectory& gt = dataset.ground_truth();
    s << "ground truth " << gt.size() << " poses, t = " << Fixed(gt.timestamps.front(), 4) << " .. "
      << Fixed(gt.timestamps.back(), 4) << "; " << dataset.size() - dataset.frames_without_gt().size()
      << " of " << dataset.size() << " frames covered";
    if (!dataset.frames_without_gt().empty()) {
      s << "; without ground truth: frames " << Ranges(dataset.frames_without_gt());
    }
    s << "\n";
  } else {
    s << "ground truth none (no groundtruth.txt)\n";
  }
  if (scan != nullptr) {
    s << "decoded      " << scan->frames_loaded << " frames in " << Fixed(scan->seconds, 2) << " s ("
      << Fixed(scan->seconds > 0 ? scan->frames_loaded / scan->seconds : 0.0, 1) << " frames/s)\n";
  }
  return s.str();
}

}  // namespace dypho
