#include "tracker/backend/loop_detection.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "common/check.h"
#include "tracker/backend/covisibility.h"
#include "tracker/orb_matcher.h"

namespace dypho {

bool LoopClosingOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  std::string sub;
  if (fixed_lag < 0 || fixed_lag > 1000) {
    e << "fixed_lag must be in [0, 1000] (got " << fixed_lag << ")";
  } else if (min_keyframes < 2) {
    e << "min_keyframes must be >= 2 (got " << min_keyframes << ")";
  } else if (covisible_min_shared < 1) {
    e << "covisible_min_shared must be >= 1 (got " << covisible_min_shared << ")";
  } else if (!(min_score_ratio >= 0.0) || !std::isfinite(min_score_ratio)) {
    e << "min_score_ratio must be >= 0 (got " << min_score_ratio << ")";
  } else if (!(min_score >= 0.0 && min_score <= 1.0)) {
    e << "min_score must be in [0, 1] (got " << min_score << ")";
  } else if (max_candidates < 1) {
    e << "max_candidates must be >= 1 (got " << max_candidates << ")";
  } else if (min_consistent < 0) {
    e << "min_consistent must be >= 0 (got " << min_consistent << ")";
  } else if (max_descriptor_distance < 1 || max_descriptor_distance > 256) {
    e << "max_descriptor_distance must be in [1, 256] (got " << max_descriptor_distance << ")";
  } else if (!(match_ratio > 0.0 && match_ratio <= 1.0)) {
    e << "match_ratio must be in (0, 1] (got " << match_ratio << ")";
  } else if (strong_covisibility < 1) {
    e << "strong_covisibility must be >= 1 (got " << strong_covisibility << ")";
  } else if (global_ba_iterations < 0) {
    e << "global_ba_iterations must be >= 0 (got " << global_ba_iterations << ")";
  } else if (!verification.IsValid(&sub)) {
    e << "verification: " << sub;
  } else if (!pose_graph.IsValid(&sub)) {
    e << "pose_graph: " << sub;
  } else {
    return true;
  }
  if (error != nullptr) *error = "LoopClosingOptions." + e.str();
  return false;
}

LoopDetector::LoopDetector(const LoopClosingOptions& options) : options_(options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
}

LoopCandidateMatch LoopDetector::Verify(const SparseMap& map, int kf, int candidate, double score) const {
  LoopCandidateMatch match;
  match.keyframe = kf;
  match.matched = candidate;
  match.score = score;
  // The features of both keyframes that hold a live map point.
  auto with_points = [&](int k, std::vector<Descriptor>* descriptors, std::vector<long>* ids) {
    const Keyframe& key = map.keyframes[k];
    for (size_t f = 0; f < key.size(); ++f) {
      const long id = key.map_points[f];
      if (id < 0 || map.points[id].bad) continue;
      descriptors->push_back(key.descriptors[f]);
      ids->push_back(id);
    }
  };
  std::vector<Descriptor> new_descriptors, old_descriptors;
  std::vector<long> new_ids, old_ids;
  with_points(kf, &new_descriptors, &new_ids);
  with_points(candidate, &old_descriptors, &old_ids);
  const std::vector<DescriptorMatch> matches = MatchBruteForce(
      new_descriptors, old_descriptors, options_.max_descriptor_distance, options_.match_ratio);
  std::vector<Eigen::Vector3d> old_points, new_points;
  std::vector<std::pair<long, long>> pairs;
  for (const DescriptorMatch& m : matches) {
    const long a = old_ids[m.train], b = new_ids[m.query];
    if (a == b) continue;  // already one point
    old_points.push_back(map.points[a].position);
    new_points.push_back(map.points[b].position);
    pairs.emplace_back(a, b);
  }
  if (static_cast<int>(pairs.size()) < options_.verification.min_inliers) {
    match.verification.reason = std::to_string(pairs.size()) + " 3D-3D matches (" +
                                std::to_string(options_.verification.min_inliers) + " needed)";
    return match;
  }
  match.verification = VerifyLoop3d(old_points, new_points, options_.verification);
  if (match.verification.accepted)
    for (size_t i = 0; i < pairs.size(); ++i)
      if (match.verification.inliers[i]) match.pairs.push_back(pairs[i]);
  return match;
}

LoopDetectionResult LoopDetector::Detect(const SparseMap& map, const BowDatabase& bow, int kf) {
  LoopDetectionResult result;
  const BowVector* query = bow.Vector(kf);
  if (query == nullptr || map.live_keyframes < options_.min_keyframes) {
    groups_.clear();
    return result;
  }
  // 1. Neighbours and the score to beat.
  const std::vector<std::pair<int, int>> neighbours = CovisibleKeyframes(map, kf, options_.covisible_min_shared);
  std::vector<int> exclude{kf};
  double min_score = 1.0;
  for (const auto& [k, shared] : neighbours) {
    exclude.push_back(k);
    if (const BowVector* v = bow.Vector(k)) min_score = std::min(min_score, BowScore(*query, *v));
  }
  min_score = neighbours.empty() ? options_.min_score : std::max(options_.min_score, min_score * options_.min_score_ratio);
  // 2. Candidates above it, and their groups' consistency with the last query's.
  std::vector<BowMatch> matches = bow.Query(*query, options_.max_candidates, exclude);
  std::vector<Group> groups;
  std::vector<std::pair<int, double>> accepted;  // (candidate, score)
  for (const BowMatch& m : matches) {
    if (m.score < min_score || map.keyframes[m.entry].bad) continue;
    ++result.candidates;
    Group g;
    g.keyframes.push_back(m.entry);
    for (const auto& [k, shared] : CovisibleKeyframes(map, m.entry, options_.covisible_min_shared))
      g.keyframes.push_back(k);
    std::sort(g.keyframes.begin(), g.keyframes.end());
    for (const Group& old : groups_) {
      std::vector<int> common;
      std::set_intersection(g.keyframes.begin(), g.keyframes.end(), old.keyframes.begin(), old.keyframes.end(),
                            std::back_inserter(common));
      if (!common.empty()) g.consistency = std::max(g.consistency, old.consistency + 1);
    }
    if (g.consistency >= options_.min_consistent) accepted.emplace_back(m.entry, m.score);
    groups.push_back(std::move(g));
  }
  groups_ = std::move(groups);
  result.consistent = static_cast<int>(accepted.size());
  if (result.candidates == 0) return result;
  if (accepted.empty()) {
    result.reason = std::to_string(result.candidates) + " candidates, none consistent over " +
                    std::to_string(options_.min_consistent) + " keyframes yet";
    return result;
  }
  // 3. Geometric verification; the most inliers win.
  for (const auto& [candidate, score] : accepted) {
    LoopCandidateMatch match = Verify(map, kf, candidate, score);
    if (!match.verification.accepted) {
      if (!result.reason.empty()) result.reason += "; ";
      result.reason += "keyframe " + std::to_string(candidate) + ": " + match.verification.reason;
      continue;
    }
    ++result.verified;
    if (!result.found || match.verification.num_inliers > result.loop.verification.num_inliers) {
      result.loop = std::move(match);
      result.found = true;
    }
  }
  if (result.found) {
    result.reason.clear();
    groups_.clear();  // ORB-SLAM: the groups start again after a loop
  }
  return result;
}

}  // namespace dypho
