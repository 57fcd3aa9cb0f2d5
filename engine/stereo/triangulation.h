// ELAS stage 3: Delaunay triangulation of the support points (cv::Subdiv2D) and
// the piecewise-planar disparity prior mu(u, v) it defines.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "engine/stereo/support_points.h"

namespace dypho::stereo {

// mu(u, v) = a u + b v + c of the triangle holding the pixel, CV_32F; NaN where
// no triangle covers it. For the right image (right_image = true) the support
// points are moved to (u - d, v) first (clamped to the image).
cv::Mat PlanePrior(const std::vector<SupportPoint>& points, cv::Size size, bool right_image);

}  // namespace dypho::stereo
