// The fixed layout of the synthetic harbour. World frame: metres, z up, the
// water surface is the plane z = 0 (unbounded); the camera boat sails along
// +x near y = 0 and looks towards +y, at the shore.
//
//   y < kQuayY           water (the passing boat crosses it at kBoatY)
//   y = kQuayY           the quay wall (stone, from the water up to kPromenadeZ)
//   y in [kQuayY, ...]   the promenade at z = kPromenadeZ: a railing along the
//                        edge, trees, pedestrians, then buildings from y = 16 m
//   a wooden dock        reaches from the quay into the water
// Every shore surface is painted in warm or green hues (reds, browns,
// yellows, greens) and water and sky are blue, as the hue-based shore
// segmentation (masking/shore_segmentation.h) expects of a real harbour.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "common/rigid3.h"
#include "engine/synth/texture.h"

namespace dypho::synth {

constexpr double kQuayY = 9.0;         // the quay's edge [m]
constexpr double kPromenadeZ = 0.8;    // the promenade's height above the water [m]
constexpr double kBoatY = 5.6;         // the passing boat's keel line [m]
constexpr double kCameraHeight = 1.6;  // the camera above the water [m]

// One box of the shore. The texture is painted as `material`, then recoloured
// to `hue` (HSV hue in [0, 1]) keeping its brightness pattern (so corners stay
// where the pattern has them); textured = false gives a flat colour of that hue.
struct ShoreBox {
  Rigid3d world_from_box;  // centre and orientation
  Eigen::Vector3d size;    // edge lengths [m]
  Material material = Material::kCabinet;  // front faces (+-x, +-y)
  Material top_material = Material::kFloor;
  double hue = 0.05;         // front faces
  double top_hue = 0.05;     // top and bottom faces
  double saturation = 0.6;   // HSV saturation of the recoloured texture
  bool textured = true;      // false: flat colour (railings)
};

// The static shore: quay, promenade, buildings, trees, railing, dock, bollards.
// Deterministic for `seed` (building sizes and hues vary).
std::vector<ShoreBox> ShoreLayout(uint64_t seed);

// Recolours a painted texture into `hue` with `saturation`: value = 0.18 +
// 0.8 * luminance, so the pattern's contrast (its corners) is kept.
Texture Recolour(const Texture& texture, double hue, double saturation);

}  // namespace dypho::synth
