// An inverted index over bag-of-words vectors (tracker/backend/vocabulary.h):
// for every word, the entries (keyframes) whose vector holds it. A query
// visits only the entries that share a word with it and scores them with
// the L1 score (DBoW2), accumulated over the shared words:
//   s = 1 - 0.5 |q - v|_1 = 0.5 * sum_shared (|q_w| + |v_w| - |q_w - v_w|)
// for unit-L1 vectors.
#pragma once

#include <unordered_map>
#include <utility>
#include <vector>

#include "tracker/backend/vocabulary.h"

namespace dypho {

struct BowMatch {
  int entry = -1;
  double score = 0.0;  // L1 score in [0, 1]
};

class BowDatabase {
 public:
  // Adds (or replaces) entry `id`.
  void Add(int id, const BowVector& v);
  // Removes entry `id` (nothing when absent).
  void Erase(int id);
  // The entries sharing a word with `q`, best score first (ties: lower id),
  // at most max_results (0 = all); entries in `exclude` are skipped.
  std::vector<BowMatch> Query(const BowVector& q, int max_results, const std::vector<int>& exclude = {}) const;
  const BowVector* Vector(int id) const;
  size_t size() const { return vectors_.size(); }

 private:
  std::unordered_map<int, BowVector> vectors_;
  std::unordered_map<int, std::vector<std::pair<int, double>>> index_;  // word -> (entry, weight)
};

}  // namespace dypho
