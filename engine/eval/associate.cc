#include "engine/eval/associate.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "common/check.h"

namespace dypho {

std::vector<TimestampMatch> AssociateTimestamps(const std::vector<double>& first,
                                                const std::vector<double>& second, double max_difference,
                                                double offset) {
  DYPHO_CHECK_INPUT(std::is_sorted(first.begin(), first.end()) &&
                    std::is_sorted(second.begin(), second.end()))
      << "AssociateTimestamps: timestamps must be sorted ascending";
  DYPHO_CHECK_INPUT(std::isfinite(max_difference) && max_difference >= 0)
      << "AssociateTimestamps: max_difference must be finite and >= 0 (got " << max_difference << ")";

  // Candidates: for each first stamp, the window of second stamps within
  // max_difference (found by binary search instead of the all-pairs loop of
  // associate.py; the candidate set is the same).
  struct Candidate {
    double diff;
    double a;
    double b;
    size_t i;
    size_t j;
  };
  // The window is slightly wider than max_difference so that rounding never
  // hides a candidate; the exact test below decides.
  const double window = max_difference * (1.0 + 1e-9) + 1e-12;
  std::vector<Candidate> candidates;
  for (size_t i = 0; i < first.size(); ++i) {
    const double a = first[i];
    auto lo = std::lower_bound(second.begin(), second.end(), a - offset - window);
    for (auto it = lo; it != second.end() && *it + offset <= a + window; ++it) {
      const double diff = std::abs(a - (*it + offset));
      if (diff < max_difference) {
        candidates.push_back({diff, a, *it, i, static_cast<size_t>(it - second.begin())});
      }
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
    return std::tie(x.diff, x.a, x.b, x.i, x.j) < std::tie(y.diff, y.a, y.b, y.i, y.j);
  });

  std::vector<char> first_used(first.size(), 0), second_used(second.size(), 0);
  std::vector<TimestampMatch> matches;
  for (const Candidate& c : candidates) {
    if (first_used[c.i] || second_used[c.j]) continue;
    first_used[c.i] = second_used[c.j] = 1;
    matches.push_back({c.i, c.j});
  }
  std::sort(matches.begin(), matches.end(),
            [](const TimestampMatch& x, const TimestampMatch& y) { return x.first < y.first; });
  return matches;
}

size_t FindClosestIndex(const std::vector<double>& sorted, double t) {
  DYPHO_CHECK_INPUT(!sorted.empty()) << "FindClosestIndex: empty list";
  // Binary search that remembers the best element among those it visits;
  // on a sorted list both neighbours of t are visited, so the result is the
  // closest element.
  size_t begin = 0, end = sorted.size(), best = 0;
  double best_diff = std::abs(sorted[0] - t);
  while (begin < end) {
    const size_t middle = (begin + end) / 2;
    const double diff = std::abs(sorted[middle] - t);
    if (diff < best_diff) {
      best_diff = diff;
      best = middle;
    }
    if (sorted[middle] == t) return middle;
    if (sorted[middle] > t) {
      end = middle;
    } else {
      begin = middle + 1;
    }
  }
  return best;
}

}  // namespace dypho
