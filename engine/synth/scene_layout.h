// The fixed layout of the synthetic room. World frame: metres, z up
// (gravity along -z), floor at z = 0; the room spans
// [kRoomMinX, kRoomMaxX] x [kRoomMinY, kRoomMaxY] x [0, kRoomHeight].
// The camera presets stay near CameraHome() and look towards +y, at
// LookTarget(); furniture stands along the walls, and the walkers use the
// open floor between the camera and the far wall (y = kRoomMaxY).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "common/rigid3.h"
#include "engine/synth/texture.h"

namespace dypho::synth {

constexpr double kRoomMinX = -3.0;
constexpr double kRoomMaxX = 3.0;
constexpr double kRoomMinY = -2.5;
constexpr double kRoomMaxY = 3.5;
constexpr double kRoomHeight = 2.7;

// Where the camera presets are centred [m, world].
inline Eigen::Vector3d CameraHome() { return Eigen::Vector3d(0.0, -1.3, 1.45); }
// The point the presets look at ("room centre" of the view) [m, world].
inline Eigen::Vector3d LookTarget() { return Eigen::Vector3d(0.0, 1.5, 0.9); }

// Walkers' centres stay within |x| <= kWalkXMax and y <= kWalkYFar; the near
// limit is chosen per sequence (camera clearance and coverage).
constexpr double kWalkXMax = 1.85;
constexpr double kWalkYFar = 2.35;

struct FurnitureBox {
  Rigid3d world_from_box;  // centre and orientation
  Eigen::Vector3d size;    // edge lengths [m]
  Material material;       // look of the front (+-x, +-y) faces
  Material top_material;   // look of the top and bottom faces
};

// The furniture: a shelf with books, a desk with a monitor, a side table, a
// cabinet, a pillar and cubes. Independent of the seed.
std::vector<FurnitureBox> FurnitureLayout();

}  // namespace dypho::synth
