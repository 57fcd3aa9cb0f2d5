#include "engine/stereo/pair_depth.h"

#include <algorithm>
#include <string>

#include <opencv2/imgproc.hpp>

#include "common/check.h"

namespace dypho::stereo {

cv::Mat PairDepth(const cv::Mat& left, const cv::Mat& right, const DisparityOptions& options, double focal_px,
                  double baseline_m, double min_disparity, int downscale, double* seconds) {
  DYPHO_CHECK_INPUT(downscale >= 1 && downscale <= 8) << "stereo depth downscale must be 1..8 (got " << downscale << ")";
  if (downscale == 1) {
    const DisparityResult d = ComputeDisparity(left, right, options);
    if (seconds) *seconds = d.seconds;
    return DisparityToDepth(d.disparity, d.valid & (d.confidence > 0), focal_px, baseline_m, min_disparity);
  }
  const cv::Size small(std::max(1, left.cols / downscale), std::max(1, left.rows / downscale));
  cv::Mat left_small, right_small;
  cv::resize(left, left_small, small, 0, 0, cv::INTER_AREA);
  cv::resize(right, right_small, small, 0, 0, cv::INTER_AREA);
  DisparityOptions o = options;
  o.elas.max_disparity = std::max(4, options.elas.max_disparity / downscale);
  // Lengths in pixels follow the image: support candidates, the support
  // grid and the smallest kept segment keep their size in the scene.
  o.elas.candidate_step = std::max(2, (options.elas.candidate_step + downscale - 1) / downscale);
  o.elas.grid_size = std::max(4, options.elas.grid_size / downscale);
  o.elas.speckle_size = std::max(4, options.elas.speckle_size / (downscale * downscale));
  o.sgbm.max_disparity = std::max(o.sgbm.min_disparity + 4, options.sgbm.max_disparity / downscale);
  const DisparityResult d = ComputeDisparity(left_small, right_small, o);
  if (seconds) *seconds = d.seconds;
  cv::Mat disparity, matched;
  cv::resize(d.disparity * static_cast<double>(downscale), disparity, left.size(), 0, 0, cv::INTER_NEAREST);
  cv::resize(d.valid & (d.confidence > 0), matched, left.size(), 0, 0, cv::INTER_NEAREST);
  return DisparityToDepth(disparity, matched, focal_px, baseline_m, min_disparity);
}

}  // namespace dypho::stereo
