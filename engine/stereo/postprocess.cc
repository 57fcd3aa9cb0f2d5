#include "engine/stereo/postprocess.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>

namespace dypho::stereo {

int LeftRightCheck(cv::Mat& disparity_left, const cv::Mat& disparity_right, float threshold) {
  std::atomic<int> removed{0};
  cv::parallel_for_(cv::Range(0, disparity_left.rows), [&](const cv::Range& rows) {
    int n = 0;
    for (int v = rows.start; v < rows.end; ++v) {
      float* l = disparity_left.ptr<float>(v);
      const float* r = disparity_right.ptr<float>(v);
      for (int u = 0; u < disparity_left.cols; ++u) {
        if (l[u] < 0) continue;
        const int ur = int(std::lround(u - l[u]));
        if (ur < 0 || r[ur] < 0 || std::abs(r[ur] - l[u]) > threshold) l[u] = -1.f, ++n;
      }
    }
    removed += n;
  });
  return removed;
}

int RemoveSmallSegments(cv::Mat& disparity, int min_size, float max_step) {
  if (min_size <= 0) return 0;
  cv::Mat fixed(disparity.size(), CV_16S);
  for (int v = 0; v < disparity.rows; ++v) {
    const float* d = disparity.ptr<float>(v);
    int16_t* f = fixed.ptr<int16_t>(v);
    for (int u = 0; u < disparity.cols; ++u) f[u] = d[u] < 0 ? int16_t(-16) : int16_t(std::lround(d[u] * 16));
  }
  cv::filterSpeckles(fixed, -16, min_size, double(max_step * 16));
  int removed = 0;
  for (int v = 0; v < disparity.rows; ++v) {
    float* d = disparity.ptr<float>(v);
    const int16_t* f = fixed.ptr<int16_t>(v);
    for (int u = 0; u < disparity.cols; ++u)
      if (d[u] >= 0 && f[u] == -16) d[u] = -1.f, ++removed;
  }
  return removed;
}

namespace {

// One line of n values at stride `step` (floats); marks filled pixels.
void FillLine(float* d, uint8_t* filled, int n, int step, int filled_step, int max_width,
              float smooth_threshold, bool extrapolate) {
  int i = 0;
  while (i < n) {
    if (d[i * step] >= 0) { ++i; continue; }
    const int start = i;
    while (i < n && d[i * step] < 0) ++i;
    const int end = i;  // run [start, end)
    const int length = end - start;
    if (length > max_width) continue;
    const bool has_a = start > 0, has_b = end < n;
    if (!has_a && !has_b) continue;
    if ((!has_a || !has_b) && !extrapolate) continue;
    const float a = has_a ? d[(start - 1) * step] : d[end * step];
    const float b = has_b ? d[end * step] : a;
    const bool smooth = std::abs(a - b) < smooth_threshold;
    for (int k = start; k < end; ++k) {
      const float t = float(k - start + 1) / float(length + 1);
      d[k * step] = smooth ? a + t * (b - a) : std::min(a, b);
      filled[k * filled_step] = 255;
    }
  }
}

}  // namespace

void InterpolateGaps(cv::Mat& disparity, int max_width, float smooth_threshold,
                     bool extrapolate_borders, cv::Mat& filled) {
  if (max_width <= 0) return;
  CV_Assert(disparity.isContinuous() && filled.isContinuous());
  const int w = disparity.cols, h = disparity.rows;
  // Rows, then columns; the lines of each pass are independent.
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v)
      FillLine(disparity.ptr<float>(v), filled.ptr<uint8_t>(v), w, 1, 1, max_width, smooth_threshold,
               extrapolate_borders);
  });
  cv::parallel_for_(cv::Range(0, w), [&](const cv::Range& columns) {
    for (int u = columns.start; u < columns.end; ++u)
      FillLine(disparity.ptr<float>(0) + u, filled.ptr<uint8_t>(0) + u, h, w, w, max_width,
               smooth_threshold, extrapolate_borders);
  });
}

}  // namespace dypho::stereo
