// glTF 2.0 export with the KHR_gaussian_splatting extension (Khronos,
// extensions/2.0/Khronos/KHR_gaussian_splatting/README.md in
// KhronosGroup/glTF, release-candidate text; scale is linear since the
// change discussed in KhronosGroup/glTF issue #2563). Written with tinygltf.
//
// Container, chosen by the file extension:
//   .glb   binary glTF: one file, JSON chunk + BIN chunk (recommended);
//   .gltf  JSON with the buffer embedded as a base64 data URI (one file, ~4/3
//          the size; no sidecar .bin, so the write stays atomic).
//
// Content: one scene, one node, one mesh, one primitive with mode POINTS (0)
// and the extension object
//   {"kernel": "ellipse", "colorSpace": "srgb_rec709_display",
//    "projection": "perspective", "sortingMethod": "cameraDistance"}
// "KHR_gaussian_splatting" is listed in extensionsUsed only (not in
// extensionsRequired), as the extension asks: a viewer without it still shows
// the map as a coloured point cloud. Attributes, each in its own buffer view,
// all tightly packed:
//   POSITION                                   VEC3  float (with min/max)
//   COLOR_0                                    VEC4  unsigned byte normalized:
//                                              fallback colour clamp(0.5 + C0 f_dc)
//                                              and opacity (the extension's
//                                              "Improving Fallback with COLOR_0")
//   KHR_gaussian_splatting:ROTATION            VEC4  float, unit quaternion x y z w
//   KHR_gaussian_splatting:SCALE               VEC3  float, linear: exp(log_scale)
//   KHR_gaussian_splatting:OPACITY             SCALAR float, sigmoid(opacity_logit)
//   KHR_gaussian_splatting:SH_DEGREE_l_COEF_n  VEC3  float (r, g, b), for every
//                                              degree l the map holds, n = 0..2l;
//                                              coefficient k = l^2 + n of the
//                                              3DGS ordering (COEF_n is order m = n - l)
//
// Coordinates: dypho's world frame is the SLAM world frame with the camera
// convention (x right, y down, z forward); glTF is right-handed with +y up and
// the viewer looking down -z. The exporter converts the data itself (no node
// matrix, so viewers that ignore node transforms still show it upright): a
// rotation by 180 degrees about x, R = diag(1, -1, -1):
//   position    p' = (x, -y, -z)
//   rotation    q' = (w=0, x=1, y=0, z=0) * q, i.e. (w, x, y, z) -> (-x, w, -z, y),
//               so R' = R_x R and the covariance becomes R_x Sigma R_x^T
//   SH          basis function Y_k(x, -y, -z) = s_k Y_k(x, y, z) with
//               s_k = (-1)^(degree of Y_k in y and z together), so every
//               coefficient is multiplied by s_k:
//               k:   0  1  2  3  4  5  6  7  8  9 10 11 12 13 14 15
//               s_k: +  -  -  +  -  +  +  -  +  -  +  -  -  +  -  +
//   scale and opacity are unchanged.
//
// An empty cloud cannot be written (glTF accessors need count >= 1): it is an
// InvalidInput error.
#pragma once

#include <string>

#include "engine/gaussians.h"

namespace dypho {

// Writes `cloud` as .glb or .gltf (by the extension of `path`) atomically.
// Throws InvalidInput for another extension, an empty or inconsistent cloud,
// non-finite values, a zero quaternion, or a scale that overflows float32.
void SaveGltf(const GaussianCloud& cloud, const std::string& path);

// Reads a .glb or .gltf map: the first primitive with the
// KHR_gaussian_splatting attributes POSITION, ROTATION, SCALE and OPACITY,
// and SH_DEGREE_l_COEF_n for every degree up to the highest present (each
// degree complete); without SH attributes the colour comes from COLOR_0.
// The coordinate change above is undone (it is its own inverse), scale goes
// back to log and opacity to a logit (clamped to +-16.6, the logit of
// 1 - 2^-24, where float32 sigmoid saturates). Attributes must be float
// (COLOR_0 also normalized unsigned byte or short), not sparse, and one
// count for all. A node transform is not applied (dypho writes none).
// Throws InvalidInput naming the file and the attribute otherwise.
GaussianCloud LoadGltf(const std::string& path);

}  // namespace dypho
