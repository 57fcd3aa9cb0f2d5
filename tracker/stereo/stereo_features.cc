#include "tracker/stereo/stereo_features.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "common/check.h"
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
  } else if (prior_search_px < 1 || prior_search_px > 20) {
    e << "prior_search_px must be in [1, 20] (got " << prior_search_px << ")";
  } else if (prior_max_range_px < 3) {
    e << "prior_max_range_px must be >= 3 (got " << prior_max_range_px << ")";
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

// Step 4 over right columns ur in [ur_lo, ur_hi] for the left pixel (ul, v):
// the sub-pixel disparity and its SAD, or false (no window fits, or the best
// column is at an end of the range).
bool BestRowShift(const cv::Mat& l, const cv::Mat& r, int ul, int v, int ur_lo, int ur_hi, int half,
                  std::vector<int>* costs, double* disparity, int* best_sad) {
  if (ur_hi - ur_lo < 2) return false;
  costs->assign(static_cast<size_t>(ur_hi - ur_lo + 1), -1);
  int best = std::numeric_limits<int>::max(), best_i = -1;
  for (int ur = ur_lo; ur <= ur_hi; ++ur) {
    const int c = PatchSad(l, r, ul, ur, v, half);
    (*costs)[ur - ur_lo] = c;
    if (c >= 0 && c < best) best = c, best_i = ur - ur_lo;
  }
  if (best_i <= 0 || best_i >= ur_hi - ur_lo) return false;
  const int cm = (*costs)[best_i - 1], c0 = (*costs)[best_i], cp = (*costs)[best_i + 1];
  if (cm < 0 || cp < 0) return false;
  double shift = 0.0;
  const double curvature = double(cm) - 2.0 * c0 + cp;
  if (curvature > 0) shift = std::clamp(0.5 * (cm - cp) / curvature, -1.0, 1.0);
  *disparity = ul - (ur_lo + best_i + shift);
  *best_sad = best;
  return true;
}

// Step 5: the matches with a SAD at most outlier_factor x the median get a depth.
std::vector<float> DepthsWithoutSadOutliers(const std::vector<int>& sad, const std::vector<float>& disparity,
                                            double fx, const StereoFeatureOptions& o, StereoFeatureStats* stats) {
  std::vector<float> depth(sad.size(), 0.0f);
  std::vector<int> kept;
  for (int c : sad)
    if (c >= 0) kept.push_back(c);
  if (kept.empty()) return depth;
  std::nth_element(kept.begin(), kept.begin() + kept.size() / 2, kept.end());
  const double limit = o.outlier_factor * kept[kept.size() / 2];
  int matched = 0;
  for (size_t i = 0; i < sad.size(); ++i) {
    if (sad[i] < 0 || sad[i] > limit) continue;
    depth[i] = static_cast<float>(fx * o.baseline / disparity[i]);
    ++matched;
  }
  if (stats) stats->matched = matched;
  return depth;
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
  std::vector<int> sad(left.size(), -1), costs;
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
    double d = 0.0;
    int best_sad = 0;
    if (!BestRowShift(left_gray, right_gray, ul, v, ur0 - o.search_px, ur0 + o.search_px, half, &costs, &d,
                      &best_sad))
      continue;
    if (d < o.min_disparity || d > o.max_disparity) continue;
    disparity[i] = float(d);
    sad[i] = best_sad;
  }
  // 5. SAD outliers, then depth.
  return DepthsWithoutSadOutliers(sad, disparity, fx, o, stats);
}

std::vector<float> StereoFeatureDepthsFromPrior(const OrbFeatures& left, const cv::Mat& prior,
                                                const cv::Mat& left_gray, const cv::Mat& right_gray, double fx,
                                                const StereoFeatureOptions& o, StereoFeatureStats* stats) {
  if (stats) *stats = StereoFeatureStats{static_cast<int>(left.size()), 0, 0};
  const int n = prior.cols > 0 ? left_gray.cols / prior.cols : 0;
  DYPHO_CHECK_INPUT(prior.type() == CV_32FC1 && n >= 1 && prior.cols * n == left_gray.cols &&
                    prior.rows * n == left_gray.rows)
      << "stereo depth prior: " << prior.cols << "x" << prior.rows << " (type " << prior.type()
      << ") must be a CV_32FC1 image whose size divides the image's " << left_gray.cols << "x" << left_gray.rows;
  const int half = o.window_px / 2;
  std::vector<int> sad(left.size(), -1), costs;
  std::vector<float> disparity(left.size(), 0.0f);
  for (size_t i = 0; i < left.size(); ++i) {
    const cv::KeyPoint& k = left.keypoints[i];
    const int ul = int(std::lround(k.pt.x)), v = std::clamp(int(std::lround(k.pt.y)), 0, left_gray.rows - 1);
    const int px = std::clamp(ul / n, 0, prior.cols - 1), py = v / n;
    double d_lo = std::numeric_limits<double>::infinity(), d_hi = -d_lo;
    for (int y = std::max(0, py - 1); y <= std::min(prior.rows - 1, py + 1); ++y) {
      const float* row = prior.ptr<float>(y);
      for (int x = std::max(0, px - 1); x <= std::min(prior.cols - 1, px + 1); ++x) {
        if (!(std::isfinite(row[x]) && row[x] > 0.0f)) continue;
        const double d = fx * o.baseline / row[x];
        d_lo = std::min(d_lo, d), d_hi = std::max(d_hi, d);
      }
    }
    if (!(d_hi >= d_lo)) continue;  // no prior around the feature
    const int dmin = std::max(0, int(std::floor(d_lo)) - o.prior_search_px);
    const int dmax = int(std::ceil(d_hi)) + o.prior_search_px;
    if (dmax - dmin > o.prior_max_range_px || dmax < o.min_disparity || dmin > o.max_disparity) continue;
    double d = 0.0;
    int best_sad = 0;
    if (!BestRowShift(left_gray, right_gray, ul, v, ul - dmax, ul - dmin, half, &costs, &d, &best_sad)) continue;
    if (d < o.min_disparity || d > o.max_disparity) continue;
    disparity[i] = float(d);
    sad[i] = best_sad;
  }
  return DepthsWithoutSadOutliers(sad, disparity, fx, o, stats);
}

}  // namespace dypho
