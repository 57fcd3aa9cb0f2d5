#include "tracker/backend/loop_correction.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "common/check.h"
#include "tracker/backend/covisibility.h"

namespace dypho {
namespace {

// Moves every observation of point `from` to point `to` (dropping those of
// keyframes that already see `to`); `from` ends up bad.
void FusePoint(long from, long to, SparseMap* map) {
  const std::vector<int> kfs = map->points[from].keyframes;
  const std::vector<int> features = map->points[from].features;
  std::set<int> seen(map->points[to].keyframes.begin(), map->points[to].keyframes.end());
  for (size_t j = 0; j < kfs.size(); ++j) {
    map->EraseObservation(kfs[j], features[j]);
    if (seen.insert(kfs[j]).second) map->AddObservation(to, kfs[j], features[j]);
  }
  MapPoint& a = map->points[to];
  const MapPoint& b = map->points[from];
  a.visible += b.visible;
  a.found += b.found;
  if (!b.bad) map->SetPointBad(from);
}

}  // namespace

int FuseLoopPairs(const std::vector<std::pair<long, long>>& pairs, SparseMap* map) {
  int fused = 0;
  const long n = static_cast<long>(map->points.size());
  for (const auto& [old_id, new_id] : pairs) {
    DYPHO_CHECK(old_id >= 0 && old_id < n && new_id >= 0 && new_id < n)
        << "FuseLoopPairs: point " << old_id << " or " << new_id << " of " << n;
    if (map->points[old_id].bad || map->points[new_id].bad || old_id == new_id) continue;
    FusePoint(new_id, old_id, map);
    ++fused;
  }
  return fused;
}

void MoveCulledKeyframes(const std::vector<Rigid3d>& old_world_from_cam, std::vector<Rigid3d>* world_from_cam,
                         const SparseMap& map) {
  const int n = static_cast<int>(map.keyframes.size());
  for (int k = 0; k < n; ++k) {
    if (!map.keyframes[k].bad) continue;
    int nearest = -1;
    for (int d = 1; d < n && nearest < 0; ++d) {
      if (k - d >= 0 && !map.keyframes[k - d].bad) {
        nearest = k - d;
      } else if (k + d < n && !map.keyframes[k + d].bad) {
        nearest = k + d;
      }
    }
    if (nearest >= 0)
      (*world_from_cam)[k] = (*world_from_cam)[nearest] * old_world_from_cam[nearest].Inverse() * old_world_from_cam[k];
  }
}

LoopCorrection CloseLoop(const LoopCandidateMatch& loop, const LoopClosingOptions& options, SparseMap* map) {
  DYPHO_CHECK(loop.verification.accepted) << "CloseLoop: the loop was not verified";
  const int n = static_cast<int>(map->keyframes.size());
  DYPHO_CHECK(loop.keyframe >= 0 && loop.keyframe < n && loop.matched >= 0 && loop.matched < n)
      << "CloseLoop: keyframes " << loop.keyframe << ", " << loop.matched << " of " << n;
  LoopCorrection out;
  out.keyframe = loop.keyframe;
  out.matched = loop.matched;
  std::vector<Rigid3d> old_world_from_cam(n), world_from_cam(n);
  for (int k = 0; k < n; ++k) old_world_from_cam[k] = world_from_cam[k] = map->keyframes[k].cam_from_world.Inverse();

  // 1. Spanning tree and strong covisibility, from the poses as they are.
  std::vector<PoseGraphEdge> edges;
  auto edge = [&](int a, int b, const std::vector<Rigid3d>& poses) {
    PoseGraphEdge e;
    e.a = a;
    e.b = b;
    e.a_from_b = poses[a].Inverse() * poses[b];
    edges.push_back(e);
  };
  std::set<std::pair<int, int>> joined;
  int previous = -1;
  for (int k = 0; k < n; ++k) {
    if (map->keyframes[k].bad) continue;
    const std::vector<std::pair<int, int>> covisible = CovisibleKeyframes(*map, k, 1);
    int parent = -1, best = 0;
    for (const auto& [j, shared] : covisible) {
      if (j < k && shared > best) {
        parent = j;
        best = shared;
      }
      if (j < k && shared >= options.strong_covisibility && joined.insert({j, k}).second) edge(j, k, world_from_cam);
    }
    if (parent < 0) parent = previous;
    if (parent >= 0 && joined.insert({parent, k}).second) edge(parent, k, world_from_cam);
    previous = k;
  }

  // 2. The new keyframe's window moves with the correction; fusion.
  std::vector<int> window{loop.keyframe};
  for (const auto& [k, shared] : CovisibleKeyframes(*map, loop.keyframe, options.covisible_min_shared))
    if (k != loop.matched) window.push_back(k);
  const Rigid3d& old_from_drifted = loop.verification.a_from_b;
  for (int k : window) world_from_cam[k] = old_from_drifted * world_from_cam[k];
  out.window = static_cast<int>(window.size());
  out.fused = FuseLoopPairs(loop.pairs, map);

  // 3. Loop edges: the loop pair, and window keyframes that now share points
  //    with the matched keyframe's window.
  std::set<int> old_window{loop.matched};
  for (const auto& [k, shared] : CovisibleKeyframes(*map, loop.matched, options.covisible_min_shared))
    if (std::find(window.begin(), window.end(), k) == window.end()) old_window.insert(k);
  const size_t before = edges.size();
  edge(loop.matched, loop.keyframe, world_from_cam);
  for (int k : window)
    for (const auto& [j, shared] : CovisibleKeyframes(*map, k, options.covisible_min_shared))
      if (old_window.count(j) && !(j == loop.matched && k == loop.keyframe) &&
          joined.insert({std::min(j, k), std::max(j, k)}).second)
        edge(j, k, world_from_cam);
  out.loop_edges = static_cast<int>(edges.size() - before);
  out.edges = static_cast<int>(edges.size());

  // 4. The graph (the matched keyframe holds the gauge), then the points.
  std::vector<char> fixed(n, 0);
  fixed[loop.matched] = 1;
  out.graph = OptimizePoseGraph(&world_from_cam, fixed, edges, options.pose_graph);
  for (MapPoint& mp : map->points) {
    if (mp.bad || mp.keyframes.empty()) continue;
    const int ref = mp.keyframes.front();
    mp.position = world_from_cam[ref] * (old_world_from_cam[ref].Inverse() * mp.position);
  }
  MoveCulledKeyframes(old_world_from_cam, &world_from_cam, *map);
  for (int k = 0; k < n; ++k) map->keyframes[k].cam_from_world = world_from_cam[k].Inverse();
  const Rigid3d moved = old_world_from_cam[loop.keyframe].Inverse() * world_from_cam[loop.keyframe];
  out.translation = (world_from_cam[loop.keyframe].translation - old_world_from_cam[loop.keyframe].translation).norm();
  out.rotation_deg = 2.0 * std::atan2(moved.rotation.vec().norm(), std::abs(moved.rotation.w())) * 180.0 / M_PI;
  return out;
}

}  // namespace dypho
