// Trajectories: timestamped camera poses `world_from_cam` (the camera's pose
// in the world: its translation is the camera centre), read and written in
// the TUM format `timestamp tx ty tz qx qy qz qw`, one pose per line, '#'
// comments allowed.
#pragma once

#include <string>
#include <vector>

#include "common/rigid3.h"

namespace dypho {

struct Trajectory {
  std::vector<double> timestamps;       // [s], strictly increasing
  std::vector<Rigid3d> world_from_cam;  // one per timestamp

  size_t size() const { return timestamps.size(); }
  bool empty() const { return timestamps.empty(); }
  void Add(double timestamp, const Rigid3d& pose) {
    timestamps.push_back(timestamp);
    world_from_cam.push_back(pose);
  }
};

// Throws InvalidInput naming the file and line on a malformed line, a
// non-finite value, a zero quaternion or a timestamp that does not increase.
Trajectory ReadTumTrajectory(const std::string& path);
// Writes atomically (temporary file, then rename); 6 decimals for times,
// 7 significant digits for poses would lose precision, so 9 decimals are used.
void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory);
// The same text as WriteTumTrajectory writes.
std::string FormatTumTrajectory(const Trajectory& trajectory);

}  // namespace dypho
