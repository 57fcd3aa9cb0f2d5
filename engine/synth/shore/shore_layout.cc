#include "engine/synth/shore/shore_layout.h"

#include <algorithm>
#include <cmath>

#include "engine/synth/random.h"

namespace dypho::synth {
namespace {

Rigid3d At(double x, double y, double z) { return Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, y, z)); }

// A box from its lower corner and size.
ShoreBox Box(double x0, double y0, double z0, double sx, double sy, double sz) {
  ShoreBox b;
  b.world_from_box = At(x0 + 0.5 * sx, y0 + 0.5 * sy, z0 + 0.5 * sz);
  b.size = Eigen::Vector3d(sx, sy, sz);
  return b;
}

}  // namespace

std::vector<ShoreBox> ShoreLayout(uint64_t seed) {
  Rng rng(Hash(seed, 0x5407e));
  std::vector<ShoreBox> boxes;
  // Quay and promenade: slabs 10 m wide from below the water to the promenade.
  for (double x = -60.0; x < 60.0; x += 10.0) {
    ShoreBox b = Box(x, kQuayY, -1.0, 10.0, 21.0, 1.0 + kPromenadeZ);
    b.material = Material::kFloor;  // stone blocks on the quay wall
    b.hue = 0.07;
    b.top_material = Material::kFloor;
    b.top_hue = 0.02;
    b.saturation = 0.55;
    boxes.push_back(b);
  }
  // Buildings along the back of the promenade.
  for (double x = -34.0; x < 34.0;) {
    const double width = rng.Uniform(4.5, 8.5);
    const double height = rng.Uniform(6.0, 13.0);
    const double y0 = 16.0 + rng.Uniform(0.0, 2.5);
    ShoreBox b = Box(x, y0, kPromenadeZ, width, rng.Uniform(6.0, 9.0), height);
    b.material = rng.Bernoulli(0.5) ? Material::kCabinet : Material::kWall;
    b.hue = rng.Uniform(0.0, 0.14);
    b.top_material = Material::kFloor;
    b.top_hue = 0.03;
    b.saturation = rng.Uniform(0.5, 0.75);
    boxes.push_back(b);
    x += width + rng.Uniform(0.8, 3.0);
  }
  // Trees on the promenade: trunk and canopy.
  for (double x = -30.0; x < 30.0; x += rng.Uniform(5.0, 8.0)) {
    const double y = 13.5 + rng.Uniform(-0.5, 0.5);
    ShoreBox trunk = Box(x - 0.15, y - 0.15, kPromenadeZ, 0.3, 0.3, 2.2);
    trunk.material = trunk.top_material = Material::kWood;
    trunk.hue = trunk.top_hue = 0.07;
    boxes.push_back(trunk);
    const double c = rng.Uniform(2.0, 3.0);
    ShoreBox canopy = Box(x - 0.5 * c, y - 0.5 * c, kPromenadeZ + 2.2, c, c, rng.Uniform(1.8, 2.8));
    canopy.material = canopy.top_material = Material::kCube;
    canopy.hue = canopy.top_hue = rng.Uniform(0.22, 0.33);
    canopy.saturation = 0.7;
    boxes.push_back(canopy);
  }
  // Railing along the quay edge: posts every 1.6 m and a top rail, yellow.
  const double rail_y = kQuayY + 0.3;
  for (double x = -40.0; x <= 40.0; x += 1.6) {
    ShoreBox post = Box(x - 0.04, rail_y - 0.04, kPromenadeZ, 0.08, 0.08, 1.0);
    post.textured = false;
    post.hue = post.top_hue = 0.13;
    post.saturation = 0.8;
    boxes.push_back(post);
  }
  for (double z : {0.55, 1.0}) {
    ShoreBox rail = Box(-40.0, rail_y - 0.04, kPromenadeZ + z, 80.0, 0.08, 0.06);
    rail.textured = false;
    rail.hue = rail.top_hue = 0.0;
    rail.saturation = 0.8;
    boxes.push_back(rail);
  }
  // A wooden dock reaching into the water at the right, on posts.
  {
    ShoreBox deck = Box(6.5, 6.6, 0.35, 3.0, kQuayY - 6.6, 0.2);
    deck.material = deck.top_material = Material::kWood;
    deck.hue = deck.top_hue = 0.08;
    boxes.push_back(deck);
    for (double x : {6.6, 9.25}) {
      for (double y : {6.7, 7.9}) {
        ShoreBox post = Box(x, y, -0.5, 0.25, 0.25, 1.6);
        post.material = post.top_material = Material::kWood;
        post.hue = post.top_hue = 0.06;
        boxes.push_back(post);
      }
    }
  }
  // Bollards on the quay.
  for (double x = -20.0; x <= 20.0; x += 7.0) {
    ShoreBox bollard = Box(x - 0.2, kQuayY + 0.6, kPromenadeZ, 0.4, 0.4, 0.6);
    bollard.material = bollard.top_material = Material::kCube;
    bollard.hue = bollard.top_hue = 0.0;
    boxes.push_back(bollard);
  }
  return boxes;
}

Texture Recolour(const Texture& texture, double hue, double saturation) {
  const int w = texture.width(), h = texture.height();
  std::vector<float> rgb(static_cast<size_t>(w) * h * 3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector3f c = texture.Texel(x, y);
      const double luminance = 0.299 * c.x() + 0.587 * c.y() + 0.114 * c.z();
      // The pattern's colour differences shift the hue a little, within the warm range.
      const double dh = 0.04 * (c.x() - c.z());
      const Eigen::Vector3f out = HsvToRgb(std::clamp(hue + dh, 0.0, 0.36), saturation, 0.18 + 0.8 * luminance);
      for (int k = 0; k < 3; ++k) rgb[(static_cast<size_t>(y) * w + x) * 3 + k] = out[k];
    }
  }
  return Texture(w, h, rgb);
}

}  // namespace dypho::synth
