#include "engine/stereo/dense_match.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/stereo/descriptor.h"

namespace dypho::stereo {

DenseMatch MatchDense(const cv::Mat& desc_ref, const cv::Mat& desc_other, const cv::Mat& texture_ref,
                      const cv::Mat& prior, const std::vector<SupportPoint>& points,
                      bool right_image, const ElasOptions& o) {
  const int w = desc_ref.cols, h = desc_ref.rows, g = o.grid_size;
  const int gw = (w + g - 1) / g, gh = (h + g - 1) / g, nd = o.max_disparity + 1;
  // Grid of candidate disparities (a flag per cell and disparity, then lists).
  std::vector<uint8_t> flags(size_t(gw) * gh * nd, 0);
  for (const SupportPoint& p : points) {
    const int u = right_image ? std::clamp(p.u - p.d, 0, w - 1) : p.u;
    const int ci = u / g, cj = p.v / g;
    for (int jj = std::max(0, cj - o.grid_radius); jj <= std::min(gh - 1, cj + o.grid_radius); ++jj)
      for (int ii = std::max(0, ci - o.grid_radius); ii <= std::min(gw - 1, ci + o.grid_radius); ++ii)
        for (int d = std::max(o.min_disparity, p.d - 1); d <= std::min(o.max_disparity, p.d + 1); ++d)
          flags[(size_t(jj) * gw + ii) * nd + d] = 1;
  }
  std::vector<std::vector<int>> cells(size_t(gw) * gh);
  for (size_t c = 0; c < cells.size(); ++c)
    for (int d = 0; d < nd; ++d)
      if (flags[c * nd + d]) cells[c].push_back(d);
  // Prior term as a table of |d - round(mu)|.
  std::vector<float> prior_cost(nd + 2 * o.plane_radius + 2);
  for (size_t k = 0; k < prior_cost.size(); ++k)
    prior_cost[k] = -std::log(o.gamma + std::exp(-float(k * k) / (2 * o.sigma * o.sigma)));
  DenseMatch out;
  out.disparity.create(h, w, CV_32F);
  out.confidence.create(h, w, CV_32F);
  const int sign = right_image ? 1 : -1;  // other-image column = u + sign * d
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    std::vector<int> candidates(size_t(nd + 2 * o.plane_radius + 1));
    std::vector<float> energies(candidates.size());
    for (int v = rows.start; v < rows.end; ++v) {
      const uint8_t* ref_row = desc_ref.ptr<uint8_t>(v);
      const uint8_t* other_row = desc_other.ptr<uint8_t>(v);
      const float* mu_row = prior.ptr<float>(v);
      const uint16_t* tex_row = texture_ref.ptr<uint16_t>(v);
      float* d_out = out.disparity.ptr<float>(v);
      float* c_out = out.confidence.ptr<float>(v);
      for (int u = 0; u < w; ++u) {
        d_out[u] = -1.f, c_out[u] = 0.f;
        if (std::isnan(mu_row[u]) || tex_row[u] < o.match_texture) continue;
        // Disparities whose match lies inside the other image, 2 px from its border
        // (where descriptors see replicated pixels).
        const int d_hi = std::min(o.max_disparity, right_image ? w - 3 - u : u - 2);
        if (d_hi < o.min_disparity) continue;
        const int mu = int(std::lround(mu_row[u]));
        // The prior puts the match outside the other image: no estimate here
        // (a choice clipped to d_hi would pass the left-right check).
        if (mu > d_hi) continue;
        const uint8_t* f = ref_row + u * kDescriptorBytes;
        // Candidates: the plane's neighbourhood, then the grid's disparities
        // outside it. Energies first, then the best (first lowest) and the
        // lowest more than 1 px from it.
        int n = 0;
        const int p_lo = std::max(o.min_disparity, mu - o.plane_radius), p_hi = std::min(d_hi, mu + o.plane_radius);
        for (int d = p_lo; d <= p_hi; ++d) candidates[n++] = d;
        for (int d : cells[size_t(v / g) * gw + u / g]) {
          if (d > d_hi) break;
          if (d < p_lo || d > p_hi) candidates[n++] = d;
        }
        if (n == 0) continue;
        const uint8_t* other = other_row + u * kDescriptorBytes;
        const ptrdiff_t stride = sign * kDescriptorBytes;
        const size_t last_prior = prior_cost.size() - 1;
        float best = std::numeric_limits<float>::max();
        int best_i = 0;
        for (int i = 0; i < n; ++i) {
          const int d = candidates[i];
          const float e = o.beta * float(DescriptorDistance(f, other + d * stride)) +
                          prior_cost[std::min<size_t>(size_t(std::abs(d - mu)), last_prior)];
          energies[i] = e;
          if (e < best) best = e, best_i = i;
        }
        const int best_d = candidates[best_i];
        float second = std::numeric_limits<float>::max();
        for (int i = 0; i < n; ++i)
          if (std::abs(candidates[i] - best_d) > 1 && energies[i] < second) second = energies[i];
        float disparity = float(best_d);
        if (o.subpixel && !right_image && best_d > o.min_disparity && best_d < d_hi) {
          const float cm = float(DescriptorDistance(f, other_row + (u - best_d + 1) * kDescriptorBytes));
          const float c0 = float(DescriptorDistance(f, other_row + (u - best_d) * kDescriptorBytes));
          const float cp = float(DescriptorDistance(f, other_row + (u - best_d - 1) * kDescriptorBytes));
          const float curvature = cm - 2 * c0 + cp;
          if (curvature > 0) disparity += std::clamp(0.5f * (cm - cp) / curvature, -0.5f, 0.5f);
        }
        d_out[u] = disparity;
        c_out[u] = second == std::numeric_limits<float>::max() ? 0.f : 1.f - std::exp(-(second - best));
      }
    }
  });
  return out;
}

}  // namespace dypho::stereo
