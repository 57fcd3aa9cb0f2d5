#include "engine/dense/voxel_map.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"

namespace dypho {
namespace {

constexpr double kPositionUnit = 1e-5;  // [m]
constexpr double kViewUnit = 1e-4;
constexpr double kInvPositionUnit = 1e5;
constexpr double kInvViewUnit = 1e4;

bool FinitePose(const Rigid3d& p) { return p.translation.allFinite() && p.rotation.coeffs().allFinite(); }

bool SamePose(const Rigid3d& a, const Rigid3d& b) {
  return a.translation == b.translation && a.rotation.coeffs() == b.rotation.coeffs();
}

}  // namespace

bool VoxelMapOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!(voxel_size > 0 && std::isfinite(voxel_size))) return fail("voxel_size must be positive and finite [m]");
  if (max_voxels < 1) return fail("max_voxels must be >= 1");
  return true;
}

VoxelMap::VoxelMap(const VoxelMapOptions& options) : options_(options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "dense map: VoxelMapOptions: " << error;
}

void VoxelMap::Integrate(Contribution* c, int sign) {
  const Rigid3d world_from_cam = c->cam_from_world.Inverse();
  const Eigen::Vector3d center = world_from_cam.translation;
  const double inv_edge = 1.0 / options_.voxel_size;
  const int n = c->points.size();
  if (sign > 0) c->in_map.assign(n, 0);
  for (int i = 0; i < n; ++i) {
    if (sign < 0 && !c->in_map[i]) continue;
    const Eigen::Vector3d p_cam(c->points.xyz[3 * i], c->points.xyz[3 * i + 1], c->points.xyz[3 * i + 2]);
    const Eigen::Vector3d p = world_from_cam * p_cam;
    const Eigen::Vector3d to_cam = (center - p).normalized();
    const double pw[3] = {p.x(), p.y(), p.z()};
    const VoxelKey key = KeyOf(pw, inv_edge);
    auto it = cells_.end();
    if (sign > 0 && static_cast<int64_t>(cells_.size()) < options_.max_voxels) {
      it = cells_.try_emplace(key).first;  // one lookup for a new or an existing cell
    } else {
      it = cells_.find(key);
      if (it == cells_.end()) {
        DYPHO_CHECK(sign > 0) << "dense map: removing a point from an empty cell";
        ++dropped_;  // max_voxels reached
        continue;
      }
    }
    Cell& cell = it->second;
    const int64_t w = sign * static_cast<int64_t>(c->points.weight[i]);
    for (int a = 0; a < 3; ++a) {
      // llrint: round to nearest (the default rounding mode; the same
      // value on removal as on insertion).
      cell.xyz[a] += w * std::llrint(pw[a] * kInvPositionUnit);
      cell.view[a] += w * std::llrint(to_cam[a] * kInvViewUnit);
      cell.rgb[a] += w * c->points.rgb[3 * i + a];
    }
    cell.weight += w;
    DYPHO_CHECK(cell.weight >= 0) << "dense map: negative cell weight";
    if (cell.weight == 0) cells_.erase(it);
    if (sign > 0) c->in_map[i] = 1;
  }
  if (sign < 0) {
    // Points left out at the cap are no longer counted as dropped.
    dropped_ -= std::count(c->in_map.begin(), c->in_map.end(), 0);
  }
}

void VoxelMap::AddKeyframe(int id, const Rigid3d& cam_from_world, KeyframePoints points) {
  DYPHO_CHECK_INPUT(!HasKeyframe(id)) << "dense map: keyframe " << id << " is already in the map";
  DYPHO_CHECK_INPUT(FinitePose(cam_from_world)) << "dense map: pose of keyframe " << id << " is not finite";
  DYPHO_CHECK_INPUT(points.xyz.size() == 3 * points.weight.size() && points.rgb.size() == points.xyz.size())
      << "dense map: keyframe " << id << ": inconsistent point arrays";
  Contribution& c = keyframes_[id];
  c.cam_from_world = cam_from_world;
  c.points = std::move(points);
  Integrate(&c, +1);
}

void VoxelMap::SetKeyframePose(int id, const Rigid3d& cam_from_world) {
  auto it = keyframes_.find(id);
  DYPHO_CHECK_INPUT(it != keyframes_.end()) << "dense map: no keyframe " << id << " to move";
  DYPHO_CHECK_INPUT(FinitePose(cam_from_world)) << "dense map: pose of keyframe " << id << " is not finite";
  if (SamePose(it->second.cam_from_world, cam_from_world)) return;
  Integrate(&it->second, -1);
  it->second.cam_from_world = cam_from_world;
  Integrate(&it->second, +1);
}

void VoxelMap::RemoveKeyframe(int id) {
  auto it = keyframes_.find(id);
  DYPHO_CHECK_INPUT(it != keyframes_.end()) << "dense map: no keyframe " << id << " to remove";
  Integrate(&it->second, -1);
  keyframes_.erase(it);
}

Rigid3d VoxelMap::KeyframePose(int id) const {
  auto it = keyframes_.find(id);
  DYPHO_CHECK_INPUT(it != keyframes_.end()) << "dense map: no keyframe " << id;
  return it->second.cam_from_world;
}

VoxelPoints VoxelMap::Points(uint32_t min_weight) const {
  std::vector<std::pair<VoxelKey, const Cell*>> sorted;
  sorted.reserve(cells_.size());
  for (const auto& [key, cell] : cells_) {
    if (cell.weight >= static_cast<int64_t>(min_weight)) sorted.emplace_back(key, &cell);
  }
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  VoxelPoints out;
  const size_t n = sorted.size();
  out.points.xyz.resize(3 * n);
  out.points.rgb.resize(3 * n);
  out.view.resize(3 * n);
  out.weight.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Cell& c = *sorted[i].second;
    const double w = static_cast<double>(c.weight);
    for (int a = 0; a < 3; ++a) {
      out.points.xyz[3 * i + a] = static_cast<float>(c.xyz[a] * kPositionUnit / w);
      out.view[3 * i + a] = static_cast<float>(c.view[a] * kViewUnit / w);
      out.points.rgb[3 * i + a] = static_cast<uint8_t>(std::clamp<int64_t>((2 * c.rgb[a] + c.weight) / (2 * c.weight), 0, 255));
    }
    out.weight[i] = static_cast<uint32_t>(std::min<int64_t>(c.weight, UINT32_MAX));
  }
  return out;
}

VoxelMapStats VoxelMap::stats() const {
  VoxelMapStats s;
  s.keyframes = static_cast<int>(keyframes_.size());
  s.voxels = static_cast<int64_t>(cells_.size());
  s.dropped_points = dropped_;
  for (const auto& [id, c] : keyframes_) s.stored_points += c.points.size();
  // A hash node: the cell, its key, the next pointer and a bucket slot.
  s.bytes = cells_.size() * (sizeof(Cell) + sizeof(VoxelKey) + 2 * sizeof(void*)) +
            static_cast<size_t>(s.stored_points) * (3 * sizeof(float) + 3 + sizeof(uint32_t) + 1);
  return s;
}

}  // namespace dypho
