#include "tracker/orb_matcher.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "common/check.h"

namespace dypho {

std::vector<Descriptor> DescriptorsFromMat(const cv::Mat& descriptors) {
  std::vector<Descriptor> out;
  if (descriptors.empty()) return out;
  DYPHO_CHECK_INPUT(descriptors.type() == CV_8UC1 && descriptors.cols == 32)
      << "descriptors must be [N, 32] CV_8UC1 (got " << descriptors.rows << "x" << descriptors.cols << " type "
      << descriptors.type() << ")";
  out.resize(descriptors.rows);
  for (int i = 0; i < descriptors.rows; ++i) std::memcpy(out[i].data(), descriptors.ptr<uint8_t>(i), 32);
  return out;
}

std::vector<DescriptorMatch> MatchBruteForce(const std::vector<Descriptor>& query,
                                             const std::vector<Descriptor>& train, int max_distance,
                                             double ratio, const std::vector<char>* train_usable) {
  std::vector<DescriptorMatch> best_for_train(train.size());
  for (size_t q = 0; q < query.size(); ++q) {
    int best = std::numeric_limits<int>::max(), second = std::numeric_limits<int>::max(), best_index = -1;
    for (size_t t = 0; t < train.size(); ++t) {
      if (train_usable != nullptr && !(*train_usable)[t]) continue;
      const int d = HammingDistance(query[q], train[t]);
      if (d < best) {
        second = best;
        best = d;
        best_index = static_cast<int>(t);
      } else if (d < second) {
        second = d;
      }
    }
    if (best_index < 0 || best > max_distance) continue;
    if (second != std::numeric_limits<int>::max() && best >= ratio * second) continue;
    DescriptorMatch& slot = best_for_train[best_index];
    if (slot.query < 0 || best < slot.distance) slot = {static_cast<int>(q), best_index, best};
  }
  std::vector<DescriptorMatch> matches;
  for (const DescriptorMatch& m : best_for_train)
    if (m.query >= 0) matches.push_back(m);
  std::sort(matches.begin(), matches.end(),
            [](const DescriptorMatch& a, const DescriptorMatch& b) { return a.query < b.query; });
  return matches;
}

std::vector<char> RotationConsistent(const std::vector<float>& angle_differences, int bins) {
  std::vector<int> bin_of(angle_differences.size());
  std::vector<int> counts(bins, 0);
  for (size_t i = 0; i < angle_differences.size(); ++i) {
    float d = std::fmod(angle_differences[i], 360.0f);
    if (d < 0) d += 360.0f;
    const int b = std::min(bins - 1, static_cast<int>(d * bins / 360.0f));
    bin_of[i] = b;
    ++counts[b];
  }
  std::vector<int> order(bins);
  for (int b = 0; b < bins; ++b) order[b] = b;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return counts[a] != counts[b] ? counts[a] > counts[b] : a < b; });
  std::vector<char> keep_bin(bins, 0);
  const int largest = counts[order[0]];
  for (int k = 0; k < std::min(3, bins); ++k)
    if (counts[order[k]] > 0 && counts[order[k]] * 10 >= largest) keep_bin[order[k]] = 1;
  std::vector<char> keep(angle_differences.size());
  for (size_t i = 0; i < angle_differences.size(); ++i) keep[i] = keep_bin[bin_of[i]];
  return keep;
}

void FeatureGrid::Build(const std::vector<cv::Point2f>& points, int width, int height, int cell) {
  cell_ = std::max(1, cell);
  cols_ = std::max(1, (width + cell_ - 1) / cell_);
  rows_ = std::max(1, (height + cell_ - 1) / cell_);
  points_ = points;
  std::vector<int> bucket(points.size());
  start_.assign(static_cast<size_t>(cols_) * rows_ + 1, 0);
  for (size_t i = 0; i < points.size(); ++i) {
    const int c = std::clamp(static_cast<int>(std::floor(points[i].x / cell_)), 0, cols_ - 1);
    const int r = std::clamp(static_cast<int>(std::floor(points[i].y / cell_)), 0, rows_ - 1);
    bucket[i] = r * cols_ + c;
    ++start_[bucket[i] + 1];
  }
  for (size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
  order_.assign(points.size(), 0);
  std::vector<int> fill(start_.begin(), start_.end() - 1);
  for (size_t i = 0; i < points.size(); ++i) order_[fill[bucket[i]]++] = static_cast<int>(i);
}

void FeatureGrid::Query(float x, float y, float radius, std::vector<int>* out) const {
  out->clear();
  if (cols_ == 0 || !std::isfinite(x) || !std::isfinite(y)) return;
  const int c0 = std::clamp(static_cast<int>(std::floor((x - radius) / cell_)), 0, cols_ - 1);
  const int c1 = std::clamp(static_cast<int>(std::floor((x + radius) / cell_)), 0, cols_ - 1);
  const int r0 = std::clamp(static_cast<int>(std::floor((y - radius) / cell_)), 0, rows_ - 1);
  const int r1 = std::clamp(static_cast<int>(std::floor((y + radius) / cell_)), 0, rows_ - 1);
  const float r2 = radius * radius;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      const int b = r * cols_ + c;
      for (int k = start_[b]; k < start_[b + 1]; ++k) {
        const int i = order_[k];
        const float dx = points_[i].x - x, dy = points_[i].y - y;
        if (dx * dx + dy * dy <= r2) out->push_back(i);
      }
    }
  }
}

}  // namespace dypho
