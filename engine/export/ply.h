// The 3D Gaussian Splatting PLY: the map format every splat viewer and
// training tool reads (the layout written by the reference implementation of
// Kerbl et al. 2023, "3D Gaussian Splatting for Real-Time Radiance Field
// Rendering", and read by SuperSplat, antimatter15/splat, gsplat, nerfstudio).
//
// Layout written by SavePly: `binary_little_endian 1.0`, one `vertex` element,
// every property `float`, in this order:
//   x y z nx ny nz f_dc_0 f_dc_1 f_dc_2 f_rest_0 .. f_rest_{M-1}
//   opacity scale_0 scale_1 scale_2 rot_0 rot_1 rot_2 rot_3
// with M = 3 * (sh_coeffs - 1) = 0, 9, 24 or 45 (the SH degree follows from M).
//   - normals are written as zero (the format carries them; nothing uses them);
//   - f_dc_c is SH coefficient 0 of channel c;
//   - f_rest is channel-major: f_rest_{c*(K-1) + (k-1)} is coefficient k >= 1
//     of channel c (all red, then all green, then all blue), K = sh_coeffs;
//   - opacity is the logit, scale_i the log of the standard deviation,
//     rot_0..3 the quaternion w x y z exactly as stored (not normalised).
// Values are copied bit for bit, so SavePly then LoadPly returns an identical
// cloud.
//
// LoadPly accepts any property order and ignores properties it does not need
// (normals, extra fields from other tools) and other elements; properties may
// be any PLY scalar type (converted to float; double rounds to nearest). Both
// `binary_little_endian` and `ascii` bodies are read; `binary_big_endian` is
// rejected. It throws InvalidInput naming the file and the problem for a
// missing file, a file that is not PLY, a malformed header, a missing
// required property, an f_rest count that is not 0/9/24/45, a body shorter
// or longer than the header's vertex count says, and any NaN or infinite
// value (the message names the vertex index and property).
//
// An empty cloud is a valid map: it is written as a PLY with 0 vertices (and
// no f_rest, so it loads back with sh_coeffs = 1).
#pragma once

#include <string>

#include "engine/gaussians.h"

namespace dypho {

// Writes `cloud` to `path` atomically (temporary file, then rename). Throws
// InvalidInput if the cloud's arrays disagree in size or hold NaN/inf (the
// message names the Gaussian and field), or if the file cannot be written.
void SavePly(const GaussianCloud& cloud, const std::string& path);

// Reads a 3DGS PLY written by dypho or another tool (see above).
GaussianCloud LoadPly(const std::string& path);

}  // namespace dypho
