#include "engine/stereo/support_points.h"

#include <algorithm>
#include <climits>

#include "engine/stereo/descriptor.h"

namespace dypho::stereo {
namespace {

// Best disparity of left pixel (u, v), or -1 when it is not unique enough.
int MatchLeft(const cv::Mat& desc_left, const cv::Mat& desc_right, int u, int v,
              const ElasOptions& o) {
  const uint8_t* l = desc_left.ptr<uint8_t>(v) + u * kDescriptorBytes;
  const uint8_t* r_row = desc_right.ptr<uint8_t>(v);
  const int d_max = std::min(o.max_disparity, u - 2);  // 2 px from the border
  if (d_max - o.min_disparity < 2) return -1;
  int best = INT_MAX, best_d = -1;
  static thread_local std::vector<int> costs;
  costs.assign(d_max + 1, INT_MAX);
  for (int d = o.min_disparity; d <= d_max; ++d) {
    const int c = DescriptorDistance(l, r_row + (u - d) * kDescriptorBytes);
    costs[d] = c;
    if (c < best) best = c, best_d = d;
  }
  int second = INT_MAX;
  for (int d = o.min_disparity; d <= d_max; ++d)
    if (std::abs(d - best_d) > 1) second = std::min(second, costs[d]);
  if (second == INT_MAX || float(best) >= o.support_ratio * float(second)) return -1;
  return best_d;
}

// Best disparity of right pixel (u, v) matched back into the left row.
int MatchRight(const cv::Mat& desc_left, const cv::Mat& desc_right, int u, int v,
               const ElasOptions& o) {
  const uint8_t* r = desc_right.ptr<uint8_t>(v) + u * kDescriptorBytes;
  const uint8_t* l_row = desc_left.ptr<uint8_t>(v);
  const int d_max = std::min(o.max_disparity, desc_left.cols - 3 - u);
  int best = INT_MAX, best_d = -1;
  for (int d = o.min_disparity; d <= d_max; ++d) {
    const int c = DescriptorDistance(r, l_row + (u + d) * kDescriptorBytes);
    if (c < best) best = c, best_d = d;
  }
  return best_d;
}

}  // namespace

std::vector<SupportPoint> ComputeSupportPoints(const cv::Mat& desc_left, const cv::Mat& desc_right,
                                               const cv::Mat& texture_left,
                                               const ElasOptions& o) {
  const int w = desc_left.cols, h = desc_left.rows, step = o.candidate_step;
  const int offset = step / 2;  // candidates at offset + i * step
  const int nu = (w - offset + step - 1) / step, nv = (h - offset + step - 1) / step;
  cv::Mat grid(nv, nu, CV_32S, cv::Scalar(-1));
  cv::parallel_for_(cv::Range(0, nv), [&](const cv::Range& range) {
    for (int j = range.start; j < range.end; ++j) {
      const int v = offset + j * step;
      for (int i = 0; i < nu; ++i) {
        const int u = offset + i * step;
        if (texture_left.at<uint16_t>(v, u) < o.support_texture) continue;
        const int d = MatchLeft(desc_left, desc_right, u, v, o);
        if (d < 0) continue;
        const int d_back = MatchRight(desc_left, desc_right, u - d, v, o);
        if (d_back < 0 || std::abs(d_back - d) > o.support_lr_threshold) continue;
        grid.at<int>(j, i) = d;
      }
    }
  });
  // Consistency vote: isolated disparities are removed.
  cv::Mat kept = grid.clone();
  const int r = o.incon_window;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int d = grid.at<int>(j, i);
      if (d < 0) continue;
      int support = 0;
      for (int jj = std::max(0, j - r); jj <= std::min(nv - 1, j + r); ++jj)
        for (int ii = std::max(0, i - r); ii <= std::min(nu - 1, i + r); ++ii) {
          const int dn = grid.at<int>(jj, ii);
          if ((jj != j || ii != i) && dn >= 0 && std::abs(dn - d) <= o.incon_threshold) ++support;
        }
      if (support < o.incon_min_support) kept.at<int>(j, i) = -1;
    }
  // Redundant points: a point whose row (then column) neighbours on both sides,
  // within redundant_window cells, carry its disparity within 1 px adds nothing
  // to the planes; removing it keeps the triangulation small.
  auto redundant = [&](int j, int i, int dj, int di) {
    const int d = kept.at<int>(j, i);
    bool before = false, after = false;
    for (int k = 1; k <= o.redundant_window; ++k) {
      const int jb = j - k * dj, ib = i - k * di, ja = j + k * dj, ia = i + k * di;
      if (!before && jb >= 0 && ib >= 0 && kept.at<int>(jb, ib) >= 0)
        before = std::abs(kept.at<int>(jb, ib) - d) <= 1;
      if (!after && ja < nv && ia < nu && kept.at<int>(ja, ia) >= 0)
        after = std::abs(kept.at<int>(ja, ia) - d) <= 1;
    }
    return before && after;
  };
  if (o.redundant_window > 0) {
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i)
        if (kept.at<int>(j, i) >= 0 && redundant(j, i, 0, 1)) kept.at<int>(j, i) = -1;
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nv; ++j)
        if (kept.at<int>(j, i) >= 0 && redundant(j, i, 1, 0)) kept.at<int>(j, i) = -1;
  }
  std::vector<SupportPoint> points;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i)
      if (kept.at<int>(j, i) >= 0) points.push_back({offset + i * step, offset + j * step, kept.at<int>(j, i)});
  if (!o.add_border_points || points.empty()) return points;
  // Border points: nearest support point of each grid row / column.
  std::vector<SupportPoint> border;
  for (int j = 0; j < nv; ++j) {
    int first = -1, last = -1;
    for (int i = 0; i < nu; ++i)
      if (kept.at<int>(j, i) >= 0) { if (first < 0) first = i; last = i; }
    if (first < 0) continue;
    const int v = offset + j * step;
    border.push_back({0, v, kept.at<int>(j, first)});
    border.push_back({w - 1, v, kept.at<int>(j, last)});
  }
  for (int i = 0; i < nu; ++i) {
    int first = -1, last = -1;
    for (int j = 0; j < nv; ++j)
      if (kept.at<int>(j, i) >= 0) { if (first < 0) first = j; last = j; }
    if (first < 0) continue;
    const int u = offset + i * step;
    border.push_back({u, 0, kept.at<int>(first, i)});
    border.push_back({u, h - 1, kept.at<int>(last, i)});
  }
  // Corners: the nearest support point.
  const int corners[4][2] = {{0, 0}, {w - 1, 0}, {0, h - 1}, {w - 1, h - 1}};
  for (const auto& c : corners) {
    long best = LONG_MAX;
    int d = 0;
    for (const auto& p : points) {
      const long dist = long(p.u - c[0]) * (p.u - c[0]) + long(p.v - c[1]) * (p.v - c[1]);
      if (dist < best) best = dist, d = p.d;
    }
    border.push_back({c[0], c[1], d});
  }
  points.insert(points.end(), border.begin(), border.end());
  return points;
}

}  // namespace dypho::stereo
