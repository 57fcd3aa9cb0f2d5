// Loop detection for the ORB tracker's keyframes (after ORB-SLAM's
// LoopClosing::DetectLoop and ComputeSim3, for RGB-D without scale):
//  1. The new keyframe's covisible neighbours (sharing at least
//     covisible_min_shared points) are never candidates; the lowest
//     bag-of-words score between the keyframe and them, times
//     min_score_ratio, is the score a candidate must reach (with no
//     neighbour: min_score).
//  2. Candidates from the BoW database above that score. Each one with its
//     own covisible keyframes forms a group; a group is consistent when it
//     shares a keyframe with a group of the previous keyframe's query; a
//     candidate is accepted once its group was consistent over
//     min_consistent consecutive keyframes (temporal consistency).
//  3. Geometric verification of the accepted candidates, best score first:
//     descriptor matches between the map points of the new keyframe and of
//     the candidate give 3D-3D pairs (world positions in the drifted and in
//     the old map), checked by RANSAC + Umeyama (loop_verification.h). The
//     candidate with the most inliers wins.
// The detector keeps the groups of the last query (step 2) between calls.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "tracker/backend/bow_database.h"
#include "tracker/backend/loop_verification.h"
#include "tracker/backend/pose_graph.h"
#include "tracker/backend/sparse_map.h"

namespace dypho {

struct LoopClosingOptions {
  bool enabled = true;               // detect and close loops after every keyframe (--disable loops)
  // Detection and closure on a back-end thread (tracker/backend/loop_worker.h),
  // on a snapshot of the map, applied at a later frame; false = on the
  // tracking thread, right after the keyframe (deterministic).
  bool threaded = false;
  // Threaded: the outcome of the keyframe made at frame f is applied at
  // frame f + fixed_lag exactly (the tracker waits for a late one), so the
  // results do not depend on timing; 0 = at the first frame after it is
  // ready [frames], 0..1000. Not threaded: > 0 processes a copy on the
  // tracking thread and applies it at f + fixed_lag as a threaded run does.
  int fixed_lag = 0;
  int min_keyframes = 10;            // live keyframes in the map before loops are searched, >= 2
  int covisible_min_shared = 15;     // keyframes sharing this many points are neighbours, never candidates, >= 1
  double min_score_ratio = 0.75;     // candidates score at least this times the weakest neighbour's score, >= 0
  double min_score = 0.01;           // ... and at least this BoW score, [0, 1]
  int max_candidates = 10;           // BoW results per query, >= 1
  int min_consistent = 2;            // consecutive keyframes with consistent candidate groups, >= 0
  int max_descriptor_distance = 64;  // Hamming threshold of the 3D-3D matches [bits], 1..256
  double match_ratio = 0.8;          // best / second-best distance limit of those matches, (0, 1]
  int strong_covisibility = 100;     // essential graph: covisibility edges between keyframes sharing this many points, >= 1
  LoopVerificationOptions verification{300, 0.05, 30, 5, 1};  // 3D-3D RANSAC + Umeyama
  PoseGraphOptions pose_graph;       // essential-graph optimisation
  bool global_ba = true;             // after the pose graph: BA of all keyframes and points (matched keyframe fixed)
  int global_ba_iterations = 10;     // its LM iterations (after local_ba.first_iterations), >= 0

  bool IsValid(std::string* error) const;
};

// An accepted loop: the new keyframe `keyframe` is at the place of the old
// keyframe `matched`.
struct LoopCandidateMatch {
  int keyframe = -1;
  int matched = -1;
  double score = 0.0;                       // BoW score
  LoopVerification verification;            // a_from_b: old world from drifted world (at the keyframe)
  std::vector<std::pair<long, long>> pairs; // inlier (old point, new point) ids
};

struct LoopDetectionResult {
  int candidates = 0;   // BoW candidates above the score (step 2, before consistency)
  int consistent = 0;   // accepted by temporal consistency
  int verified = 0;     // passed geometric verification
  bool found = false;
  LoopCandidateMatch loop;  // when found
  std::string reason;       // why no loop, when candidates > 0
};

class LoopDetector {
 public:
  // Throws InvalidInput for invalid options.
  explicit LoopDetector(const LoopClosingOptions& options);
  // Steps 1-3 for keyframe `kf` (already in `bow`).
  LoopDetectionResult Detect(const SparseMap& map, const BowDatabase& bow, int kf);
  // Step 3 alone for a given candidate (tests: an injected candidate).
  LoopCandidateMatch Verify(const SparseMap& map, int kf, int candidate, double score) const;
  // Forgets the groups (a new map).
  void Reset() { groups_.clear(); }

 private:
  struct Group {
    std::vector<int> keyframes;  // sorted
    int consistency = 0;
  };
  LoopClosingOptions options_;
  std::vector<Group> groups_;  // of the last query
};

}  // namespace dypho
