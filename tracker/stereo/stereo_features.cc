#include "tracker/stereo/stereo_features.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "tracker/orb_matcher.h"

namespace dypho {

bool StereoFeatureOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  if (!(std::isfinite(baseline) && baseline >= 0)) {
    e << "stereo.baseline must be >= 0 m (got " << baseline << ")";
  } else if (!(std::isfinite(min_disparity) && min_disparity > 0)) {
    e << "min_disparity must be > 0 (got " << min_disparity << ")";
  } else if (!(std::isfinite(max_disparity) && max_disparity > min_disparity)) {
    e << "max_disparity must be > min_disparity (got " << max_disparity << ")";
  } else if (!(std::isfinite(row_band_px) && row_band_px >= 0)) {
    e << "row_band_px must be >= 0 (got " << row_band_px << ")";
  } else if (max_distance < 1 || max_distance > 256) {
    e << "max_distance must be in [1, 256] (got " << max_distance << ")";
  } else if (!(ratio > 0 && ratio <= 1)) {
    e << "ratio must be in (0, 1] (got " << ratio << ")";
  } else if (window_px < 3 || window_px > 31 || window_px % 2 == 0) {
    e << "window_px must be odd in [3, 31] (got " << window_px << ")";
  } else if (search_px < 1 || search_px > 20) {
    e << "search_px must be in [1, 20] (got " << search_px << ")";
  } else if (!(std::isfinite(outlier_factor) && outlier_factor >= 1)) {
    e << "outlier_factor must be >= 1 (got " << outlier_factor << ")";
  }
  if (error) *error = e.str();
  return e.str().empty();
}

namespace {

// SAD of the window around (ul, v) in `l` and (ur, v) in `r`; -1 when a window leaves an image.
int PatchSad(const cv::Mat& l, const cv::Mat& r, int ul, int ur, int v, int half) {
  if (v - half < 0 || v + half >= l.rows || ul - half < 0 || ul + half >= l.cols || ur - half < 0 ||
      ur + half >= r.cols)
    return -1;
  int sum = 0;
  for (int dy = -half; dy <= half; ++dy) {
    const uint8_t* a = l.ptr<uint8_t>(v + dy) + ul - half;
    const uint8_t* b = r.ptr<uint8_t>(v + dy) + ur - half;
    for (int dx = 0; dx < 2 * half + 1; ++dx) sum += std::abs(int(a[dx]) - int(b[dx]));
  }
  return sum;
}

}  // namespace

std::vector<float> StereoFeatureDepths(const OrbFeatures& left, const OrbFeatures& right, const cv::Mat& left_gray,
                                       const cv::Mat& right_gray, double fx, double scale_factor,
                                       const StereoFeatureOptions& o, StereoFeatureStats* stats) {
  std::vector<float> depth(left.size(), 0.0f);
  if (stats) *stats = StereoFeatureStats{static_cast<int>(left.size()), static_cast<int>(right.size()), 0};
  if (left.size() == 0 || right.size() == 0) return depth;
  const int rows = left_gray.rows;
  // 2. The right features serving each row.
  std::vector<std::vector<int>> by_row(rows);
  for (size_t j = 0; j < right.size(); ++j) {
    const cv::KeyPoint& k = right.keypoints[j];
    const double band = o.row_band_px * std::pow(scale_factor, k.octave);
    const int lo = std::max(0, int(std::floor(k.pt.y - band))), hi = std::min(rows - 1, int(std::ceil(k.pt.y + band)));
    for (int y = lo; y <= hi; ++y) by_row[y].push_back(static_cast<int>(j));
  }
  const std::vector<Descriptor> dl = DescriptorsFromMat(left.descriptors), dr = DescriptorsFromMat(right.descriptors);
  const int half = o.window_px / 2;
  std::vector<int> sad(left.size(), -1);
  std::vector<float> disparity(left.size(), 0.0f);
  for (size_t i = 0; i < left.size(); ++i) {
    const cv::KeyPoint& k = left.keypoints[i];
    const int v = std::clamp(int(std::lround(k.pt.y)), 0, rows - 1);
    // 3. The best descriptor match along the row.
    int best = 257, second = 257, best_j = -1;
    for (int j : by_row[v]) {
      const cv::KeyPoint& kr = right.keypoints[j];
      if (std::abs(kr.octave - k.octave) > 1) continue;
      const double d = k.pt.x - kr.pt.x;
      if (d < o.min_disparity || d > o.max_disparity) continue;
      const int dist = HammingDistance(dl[i], dr[j]);
      if (dist < best) {
        second = best, best = dist, best_j = j;
      } else if (dist < second) {
        second = dist;
      }
    }
    if (best_j < 0 || best > o.max_distance || (second <= 256 && best >= o.ratio * second)) continue;
    // 4. Sub-pixel by SAD along the row.
    const int ul = int(std::lround(k.pt.x)), ur0 = int(std::lround(right.keypoints[best_j].pt.x));
    int best_sad = std::numeric_limits<int>::max(), best_s = 0;
    std::vector<int> costs(2 * o.search_px + 1, -1);
    for (int s = -o.search_px; s <= o.search_px; ++s) {
      const int c = PatchSad(left_gray, right_gray, ul, ur0 + s, v, half);
      costs[s + o.search_px] = c;
      if (c >= 0 && c < best_sad) best_sad = c, best_s = s;
    }
    if (best_sad == std::numeric_limits<int>::max() || best_s == -o.search_px || best_s == o.search_px) continue;
    const int cm = costs[best_s + o.search_px - 1], c0 = costs[best_s + o.search_px], cp = costs[best_s + o.search_px + 1];
    if (cm < 0 || cp < 0) continue;
    double shift = 0.0;
    const double curvature = double(cm) - 2.0 * c0 + cp;
    if (curvature > 0) shift = std::clamp(0.5 * (cm - cp) / curvature, -1.0, 1.0);
    // Disparity from the feature's own position (sub-pixel) and the refined right column.
    const double d = ul - (ur0 + best_s + shift);
    if (d < o.min_disparity || d > o.max_disparity) continue;
    disparity[i] = float(d);
    sad[i] = best_sad;
  }
  // 5. SAD outliers, then depth.
  std::vector<int> kept;
  for (int c : sad)
    if (c >= 0) kept.push_back(c);
  if (kept.empty()) return depth;
  std::nth_element(kept.begin(), kept.begin() + kept.size() / 2, kept.end());
  const double limit = o.outlier_factor * kept[kept.size() / 2];
  int matched = 0;
  for (size_t i = 0; i < left.size(); ++i) {
    if (sad[i] < 0 || sad[i] > limit) continue;
    depth[i] = static_cast<float>(fx * o.baseline / disparity[i]);
    ++matched;
  }
  if (stats) stats->matched = matched;
  return depth;
}

}  // namespace dypho
