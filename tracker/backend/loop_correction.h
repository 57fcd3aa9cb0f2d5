// Closing a verified loop (loop_detection.h) on the sparse map, as ORB-SLAM
// does for RGB-D (rigid, no scale):
//  1. The essential graph from the map as it is (before any change): a
//     spanning tree (every live keyframe to the older keyframe it shares most
//     points with, else to the previous live keyframe), strong covisibility
//     edges (pairs sharing strong_covisibility points), measured from the
//     current poses.
//  2. The new keyframe's window (it and its covisible keyframes) is moved by
//     the loop's correction old_from_drifted; the verified point pairs are
//     fused (the new map point's observations go to the old one).
//  3. Loop edges between the window and the matched keyframe's window (pairs
//     that now share fused points, and the loop pair itself), measured from
//     the corrected poses.
//  4. The pose graph (pose_graph.h) with the matched keyframe fixed; every
//     live map point then moves with its reference keyframe (the first
//     keyframe observing it): p' = world_from_ref' * ref_from_world * p;
//     culled keyframes move with their nearest live keyframe.
// The tracker follows with a global BA (options.global_ba).
#pragma once

#include <utility>
#include <vector>

#include "common/rigid3.h"
#include "tracker/backend/loop_detection.h"
#include "tracker/backend/pose_graph.h"
#include "tracker/backend/sparse_map.h"

namespace dypho {

struct LoopCorrection {
  int keyframe = -1;
  int matched = -1;
  int window = 0;            // keyframes moved by the correction before the graph
  int fused = 0;             // map points fused
  int edges = 0;             // essential-graph edges
  int loop_edges = 0;        // of which loop edges
  double translation = 0.0;  // [m] how far the new keyframe moved
  double rotation_deg = 0.0; // [deg] how far it turned
  PoseGraphSummary graph;
};

// Culled keyframes (frames may still be anchored to them) move as the live
// keyframe nearest in time moved from old_world_from_cam to world_from_cam.
void MoveCulledKeyframes(const std::vector<Rigid3d>& old_world_from_cam, std::vector<Rigid3d>* world_from_cam,
                         const SparseMap& map);

// Fuses the verified (old point, new point) pairs: the new point's
// observations go to the old one, the new one becomes bad. Pairs with a bad
// point are skipped. Returns the points fused.
int FuseLoopPairs(const std::vector<std::pair<long, long>>& pairs, SparseMap* map);

// Applies `loop` (from LoopDetector::Detect or Verify, accepted) to `map`.
LoopCorrection CloseLoop(const LoopCandidateMatch& loop, const LoopClosingOptions& options, SparseMap* map);

}  // namespace dypho
