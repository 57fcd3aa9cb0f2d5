#include "tracker/backend/bow_database.h"

#include <algorithm>
#include <cmath>

namespace dypho {

void BowDatabase::Add(int id, const BowVector& v) {
  Erase(id);
  vectors_[id] = v;
  for (const auto& [w, value] : v) index_[w].emplace_back(id, value);
}

void BowDatabase::Erase(int id) {
  const auto it = vectors_.find(id);
  if (it == vectors_.end()) return;
  for (const auto& [w, value] : it->second) {
    auto& list = index_[w];
    list.erase(std::remove_if(list.begin(), list.end(), [id](const auto& e) { return e.first == id; }), list.end());
  }
  vectors_.erase(it);
}

const BowVector* BowDatabase::Vector(int id) const {
  const auto it = vectors_.find(id);
  return it == vectors_.end() ? nullptr : &it->second;
}

std::vector<BowMatch> BowDatabase::Query(const BowVector& q, int max_results, const std::vector<int>& exclude) const {
  std::unordered_map<int, double> acc;
  for (const auto& [w, qv] : q) {
    const auto it = index_.find(w);
    if (it == index_.end()) continue;
    for (const auto& [id, v] : it->second) acc[id] += std::abs(qv) + std::abs(v) - std::abs(qv - v);
  }
  std::vector<BowMatch> out;
  for (const auto& [id, s] : acc) {
    if (std::find(exclude.begin(), exclude.end(), id) != exclude.end()) continue;
    out.push_back({id, std::clamp(0.5 * s, 0.0, 1.0)});
  }
  std::sort(out.begin(), out.end(), [](const BowMatch& a, const BowMatch& b) {
    return a.score != b.score ? a.score > b.score : a.entry < b.entry;
  });
  if (max_results > 0 && static_cast<int>(out.size()) > max_results) out.resize(max_results);
  return out;
}

}  // namespace dypho
