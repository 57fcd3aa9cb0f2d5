// Procedural textures for the synthetic scene: painted from a seed in
// physical units (metres), stored with a mip chain and sampled with
// trilinear, anisotropic filtering so that rendered images do not alias.
//
// The patterns are made for feature trackers: many high-contrast rectangles
// at several scales (corners for FAST/ORB), checkerboards, stripes, book
// spines, floor tiles, plus low-frequency value noise so that no two places
// look alike.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace dypho::synth {

// An RGB texture with a mip chain (2x2 box filter). Texture coordinates
// (s, t) in [0, 1]^2: s along the width, t along the height, (0, 0) at the
// top-left corner of texel (0, 0); clamped at the border.
class Texture {
 public:
  Texture() = default;
  // `rgb`: width * height * 3 floats in [0, 1], row-major.
  Texture(int width, int height, const std::vector<float>& rgb);

  int width() const { return levels_.empty() ? 0 : levels_[0].width; }
  int height() const { return levels_.empty() ? 0 : levels_[0].height; }
  int num_levels() const { return static_cast<int>(levels_.size()); }

  // Bilinear within a level and linear between levels; lod 0 = full size.
  Eigen::Vector3f SampleTrilinear(double s, double t, double lod) const;
  // Anisotropic filtering for a pixel footprint given by the derivatives of
  // (s, t) with respect to the pixel coordinates (u, v): up to 4 trilinear
  // samples along the footprint's major axis at the minor axis' level.
  Eigen::Vector3f SampleFootprint(double s, double t, double ds_du, double dt_du, double ds_dv,
                                  double dt_dv) const;
  // The texel of level 0 (for tests).
  Eigen::Vector3f Texel(int x, int y) const;

 private:
  struct Level {
    int width = 0;
    int height = 0;
    std::vector<uint8_t> rgb;  // [height, width, 3]
  };
  Eigen::Vector3f SampleBilinear(const Level& level, double s, double t) const;
  std::vector<Level> levels_;
};

// What a surface looks like.
enum class Material {
  kWall,     // pale paint with posters, notes and small marks
  kFloor,    // tiles with grout, inset patterns and clutter
  kCeiling,  // panels, lamps, vents
  kWood,     // grain streaks with papers on it
  kBooks,    // a row of book spines with labels
  kCube,     // a checkerboard with a frame and stickers
  kCabinet,  // doors with frames, handles and stickers
  kScreen,   // a dark screen showing windows with text lines
  kShirt,    // striped or plaid cloth in `base`
  kPants,    // dark cloth with seams and pockets in `base`
  kFace,     // skin in `base` with hair in `accent`, eyes, brows and mouth
  kHead,     // skin in `base` below, hair in `accent` above
  kHair,     // hair in `accent`
  kSkin,     // plain skin in `base` with mottling
  kShoe,     // dark with a light sole band
};

struct PaintStyle {
  Material material = Material::kWall;
  Eigen::Vector3f base{0.5f, 0.5f, 0.5f};    // main colour, RGB in [0, 1] (cloth and skin)
  Eigen::Vector3f accent{0.1f, 0.1f, 0.1f};  // second colour, RGB in [0, 1] (hair)
  int variant = 0;                           // pattern variant (e.g. stripes vs plaid)
};

// Paints a texture for a surface of width_m x height_m metres at
// `texels_per_m`, deterministic for `seed`. The size is rounded up and
// clamped to [4, 2048] texels per side.
Texture PaintTexture(const PaintStyle& style, double width_m, double height_m, double texels_per_m,
                     uint64_t seed);

// HSV (all in [0, 1]) to RGB.
Eigen::Vector3f HsvToRgb(double h, double s, double v);

}  // namespace dypho::synth
