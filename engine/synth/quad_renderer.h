// A plain geometric renderer for scenes made of textured rectangles (box
// faces): exact ground truth for the Gaussian rasterizer, the tracker and
// the masks. It shares no code with kernels/.
//
// Visibility is decided per pixel centre by intersecting the pixel's ray with
// each quad's plane in double precision (a ray caster that visits, for each
// quad, only the pixels of its projected bounding box), so the depth of a
// pixel is the exact camera z of the surface point seen through its centre,
// the mask is exactly the set of pixels whose nearest surface belongs to a
// walker, and shared box edges leave no gaps. Ties keep the earlier quad.
// Colour: textures sampled with anisotropic trilinear filtering times a
// per-quad Lambertian factor; geometry edges are not anti-aliased, so colour,
// depth and mask agree on every pixel.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/synth/texture.h"

namespace dypho::synth {

// The rectangle origin + s * edge_s + t * edge_t, (s, t) in [0, 1]^2, with
// edge_s perpendicular to edge_t. Visible only from the side `normal` points
// to; normal = normalize(edge_t x edge_s), so seen from that side s runs to
// the right and t down, like image coordinates (textures appear upright).
struct Quad {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();    // world [m]
  Eigen::Vector3d edge_s = Eigen::Vector3d::UnitX();   // world [m]
  Eigen::Vector3d edge_t = Eigen::Vector3d::UnitY();   // world [m]
  Eigen::Vector3d normal = -Eigen::Vector3d::UnitZ();  // world, unit
  int texture = -1;                                    // index into the texture list; -1 = `colour`
  Eigen::Vector3f colour{0.5f, 0.5f, 0.5f};            // flat albedo when texture < 0
  float shade = 1.0f;                                  // Lambertian factor applied to the albedo
  int object = -1;                                     // -1 = static scene, k >= 0 = walker k
};

// A rectangle of width x height [m] centred at `centre`, facing `normal`,
// with `up` (perpendicular to normal) pointing to the texture's top.
Quad MakeQuad(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal, const Eigen::Vector3d& up,
              double width, double height);

// Faces of a box, in this order: +x, -x, +y, -y, +z, -z (box frame).
constexpr int kBoxFaces = 6;
// (width, height) [m] of each face of a box of `size` [m].
std::array<Eigen::Vector2d, kBoxFaces> BoxFaceSizes(const Eigen::Vector3d& size);
// The six faces of a box of `size` [m] centred at the box frame's origin.
// Vertical faces have their texture's top at +z of the box; the +-z faces at
// +y. `inward` makes the faces visible from inside (a room). Texture, colour,
// shade and object are left at their defaults.
std::array<Quad, kBoxFaces> BoxQuads(const Rigid3d& world_from_box, const Eigen::Vector3d& size,
                                     bool inward = false);

// Nearest quad per pixel centre: depth = camera z [m] in double, quad index;
// depth 0 and quad -1 where the ray hits nothing (nearer than 1e-4 m does
// not count).
struct VisibilityBuffer {
  int width = 0;
  int height = 0;
  std::vector<double> depth;  // [height * width]
  std::vector<int32_t> quad;  // [height * width]
};
VisibilityBuffer RasterizeQuads(const std::vector<Quad>& quads, const Rigid3d& cam_from_world,
                                const Camera& camera);

struct QuadRender {
  ImageU8 rgb;           // [H, W, 3]; black where nothing was hit
  ImageF depth;          // camera z [m]; 0 where nothing was hit
  ImageF cos_incidence;  // |cos| of the angle between surface normal and viewing ray; 0 = none
  ImageU8 mask;          // 255 where the visible quad belongs to a walker (object >= 0)
};
// Renders colour (skipped when `with_colour` is false: rgb stays empty),
// depth, incidence and mask. The camera must have no distortion.
QuadRender RenderQuads(const std::vector<Quad>& quads, const std::vector<Texture>& textures,
                       const Rigid3d& cam_from_world, const Camera& camera, bool with_colour = true);

}  // namespace dypho::synth
