#include "engine/synth/scene_layout.h"

#include <cmath>

#include "engine/synth/random.h"

namespace dypho::synth {
namespace {

using Eigen::Vector3d;

// Axis-aligned box from its min and max corners, turned by `yaw` [rad] about
// its vertical axis.
FurnitureBox Box(const Vector3d& lo, const Vector3d& hi, Material material, Material top, double yaw = 0.0) {
  FurnitureBox b;
  b.world_from_box = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Vector3d::UnitZ())), 0.5 * (lo + hi));
  b.size = hi - lo;
  b.material = material;
  b.top_material = top;
  return b;
}

// A cube of edge `edge` standing on height `z0` at (x, y).
FurnitureBox Cube(double x, double y, double z0, double edge, double yaw) {
  const Vector3d c(x, y, z0 + 0.5 * edge);
  return Box(c - Vector3d::Constant(0.5 * edge), c + Vector3d::Constant(0.5 * edge), Material::kCube,
             Material::kCube, yaw);
}

// Four legs and a top.
void Table(double x0, double x1, double y0, double y1, double top_z, std::vector<FurnitureBox>* out) {
  const double leg = 0.05, thick = 0.04;
  out->push_back(Box({x0, y0, top_z - thick}, {x1, y1, top_z}, Material::kWood, Material::kWood));
  for (double x : {x0, x1 - leg}) {
    for (double y : {y0, y1 - leg}) {
      out->push_back(Box({x, y, 0.0}, {x + leg, y + leg, top_z - thick}, Material::kWood, Material::kWood));
    }
  }
}

}  // namespace

std::vector<FurnitureBox> FurnitureLayout() {
  std::vector<FurnitureBox> out;
  Rng rng(0x5eed1a70u);  // the layout is the same for every seed

  // Shelf against the far wall: two sides, five boards, books on four levels.
  const double sx0 = -2.0, sx1 = -0.2, sy0 = 3.08, sy1 = kRoomMaxY, top = 2.0, t = 0.03;
  out.push_back(Box({sx0, sy0, 0.0}, {sx0 + t, sy1, top}, Material::kWood, Material::kWood));
  out.push_back(Box({sx1 - t, sy0, 0.0}, {sx1, sy1, top}, Material::kWood, Material::kWood));
  const double boards[] = {0.0, 0.48, 0.96, 1.44, top - t};
  for (double z : boards) {
    out.push_back(Box({sx0 + t, sy0, z}, {sx1 - t, sy1, z + t}, Material::kWood, Material::kWood));
  }
  for (int level = 0; level < 4; ++level) {
    const double z0 = boards[level] + t;
    double x = sx0 + t + 0.01;
    while (true) {
      const double run = rng.Uniform(0.2, 0.5);  // a run of books, then a gap
      const double x_end = std::min(x + run, sx1 - t - 0.01);
      if (x_end - x < 0.06) break;
      const double h = rng.Uniform(0.2, 0.38), d = rng.Uniform(0.2, 0.3);
      out.push_back(
          Box({x, sy1 - 0.02 - d, z0}, {x_end, sy1 - 0.02, z0 + h}, Material::kBooks, Material::kBooks));
      x = x_end + rng.Uniform(0.04, 0.2);
      if (rng.Bernoulli(0.3) && x + 0.2 < sx1 - t) {
        out.push_back(Cube(x + 0.1, sy1 - 0.2, z0, 0.16, rng.Uniform(-0.4, 0.4)));
        x += 0.25;
      }
    }
  }

  // Desk against the far wall with a drawer block, a monitor, a keyboard and cubes.
  Table(0.4, 2.2, 2.75, kRoomMaxY, 0.76, &out);
  out.push_back(Box({1.7, 2.8, 0.08}, {2.12, 3.45, 0.72}, Material::kCabinet, Material::kWood));
  out.push_back(Box({0.85, 3.22, 0.96}, {1.55, 3.27, 1.38}, Material::kScreen, Material::kCube));
  out.push_back(Box({1.17, 3.27, 0.76}, {1.23, 3.32, 0.97}, Material::kCube, Material::kCube));
  out.push_back(Box({1.0, 3.15, 0.76}, {1.4, 3.4, 0.78}, Material::kCube, Material::kCube));
  out.push_back(Box({0.95, 2.85, 0.76}, {1.45, 3.0, 0.785}, Material::kCabinet, Material::kScreen));
  out.push_back(Cube(0.6, 3.05, 0.76, 0.18, 0.35));
  out.push_back(Cube(1.95, 3.2, 0.76, 0.22, -0.2));
  out.push_back(Box({1.5, 2.82, 0.76}, {1.75, 3.02, 0.82}, Material::kBooks, Material::kCabinet, 0.1));

  // Side table along the right wall with boxes.
  Table(2.25, kRoomMaxX, -0.6, 1.4, 0.72, &out);
  out.push_back(Box({2.35, -0.4, 0.72}, {2.75, -0.05, 0.98}, Material::kCabinet, Material::kCube, 0.2));
  out.push_back(Cube(2.6, 0.5, 0.72, 0.3, -0.3));
  out.push_back(Cube(2.55, 1.05, 0.72, 0.2, 0.5));

  // Cabinet along the left wall with boxes on top.
  out.push_back(Box({kRoomMinX, 0.2, 0.0}, {-2.45, 1.6, 1.1}, Material::kCabinet, Material::kWood));
  out.push_back(Cube(-2.72, 0.55, 1.1, 0.32, 0.25));
  out.push_back(Box({-2.9, 1.0, 1.1}, {-2.55, 1.5, 1.35}, Material::kBooks, Material::kCube, -0.15));

  // A pillar and cubes on the floor.
  out.push_back(Box({2.45, -1.95, 0.0}, {2.85, -1.55, kRoomHeight}, Material::kWall, Material::kWall));
  out.push_back(Cube(-2.45, 2.75, 0.0, 0.45, 0.5));
  out.push_back(Cube(-2.45, 2.75, 0.45, 0.3, -0.2));
  out.push_back(Cube(2.55, 2.55, 0.0, 0.4, 0.15));
  out.push_back(Box({-2.85, -1.5, 0.0}, {-2.35, -0.8, 0.5}, Material::kCube, Material::kCabinet));
  return out;
}

}  // namespace dypho::synth
