#include "engine/eval/trajectory.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "common/check.h"
#include "common/files.h"

namespace dypho {

Trajectory ReadTumTrajectory(const std::string& path) {
  std::ifstream in(path);
  DYPHO_CHECK_INPUT(in.good()) << "cannot open trajectory file " << path;
  Trajectory traj;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    for (char& c : line) {
      if (c == ',') c = ' ';
    }
    std::istringstream s(line);
    double v[8];
    for (int i = 0; i < 8; ++i) {
      DYPHO_CHECK_INPUT(static_cast<bool>(s >> v[i]))
          << path << ":" << line_no << ": expected 'timestamp tx ty tz qx qy qz qw', got '" << Printable(line) << "'";
      DYPHO_CHECK_INPUT(std::isfinite(v[i]))
          << path << ":" << line_no << ": non-finite value in '" << Printable(line) << "'";
    }
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    DYPHO_CHECK_INPUT(q.norm() > 1e-6) << path << ":" << line_no << ": zero quaternion";
    DYPHO_CHECK_INPUT(traj.empty() || v[0] > traj.timestamps.back())
        << path << ":" << line_no << ": timestamp " << FormatTimestamp(v[0]) << " does not increase";
    traj.Add(v[0], Rigid3d(q, Eigen::Vector3d(v[1], v[2], v[3])));
  }
  return traj;
}

std::string FormatTumTrajectory(const Trajectory& trajectory) {
  std::string out = "# timestamp tx ty tz qx qy qz qw (world_from_cam)\n";
  char buf[256];
  for (size_t i = 0; i < trajectory.size(); ++i) {
    const Rigid3d& p = trajectory.world_from_cam[i];
    std::snprintf(buf, sizeof(buf), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n",
                  trajectory.timestamps[i], p.translation.x(), p.translation.y(), p.translation.z(),
                  p.rotation.x(), p.rotation.y(), p.rotation.z(), p.rotation.w());
    out += buf;
  }
  return out;
}

void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory) {
  WriteTextAtomically(path, FormatTumTrajectory(trajectory));
}

}  // namespace dypho
