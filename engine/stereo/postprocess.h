// ELAS stage 5: left-right check, small-segment removal, gap interpolation.
// Disparity maps here are CV_32F with -1 marking "no estimate".
#pragma once

#include <opencv2/core.hpp>

namespace dypho::stereo {

// Invalidates left disparities d whose right disparity at (u - round(d), v) is
// missing or differs by more than threshold [px]. Returns the pixels removed.
int LeftRightCheck(cv::Mat& disparity_left, const cv::Mat& disparity_right, float threshold);

// Removes 4-connected segments (neighbours differ by <= max_step px) smaller
// than min_size pixels (cv::filterSpeckles at 1/16 px). Returns the pixels removed.
int RemoveSmallSegments(cv::Mat& disparity, int min_size, float max_step);

// Fills runs of missing pixels, first along rows, then along columns: a run of
// at most max_width pixels between estimates a and b takes the linear
// interpolation of a and b when |a - b| < smooth_threshold, else min(a, b)
// (the background: occlusions lie behind). With extrapolate_borders, runs that
// touch the image border take their one neighbour's value. Sets filled(v, u) = 255
// for every filled pixel (filled: CV_8U, same size, allocated by the caller).
void InterpolateGaps(cv::Mat& disparity, int max_width, float smooth_threshold,
                     bool extrapolate_borders, cv::Mat& filled);

}  // namespace dypho::stereo
