// ELAS stage 2: robust support points, sparse matches on a regular grid.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "engine/stereo/disparity.h"

namespace dypho::stereo {

struct SupportPoint {
  int u = 0, v = 0;  // pixel of the left image
  int d = 0;         // disparity [px]
};

// Matches every candidate_step-th pixel of the left image along its row of the
// right image over [min_disparity, max_disparity]; keeps a match when
//  - its texture is at least support_texture,
//  - the best cost is below support_ratio x the best cost at |d - d_best| > 1,
//  - matching back from the right pixel finds d_best within support_lr_threshold,
//  - at least incon_min_support matches of the incon_window neighbourhood agree
//    within incon_threshold.
// With add_border_points, points on the four image borders carry the disparity
// of the nearest support point of their row or column (so the triangulation
// covers the image). descriptors: from ComputeDescriptors; texture: DescriptorTexture.
std::vector<SupportPoint> ComputeSupportPoints(const cv::Mat& desc_left, const cv::Mat& desc_right,
                                               const cv::Mat& texture_left,
                                               const ElasOptions& options);

}  // namespace dypho::stereo
