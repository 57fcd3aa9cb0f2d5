// The .splat format of the antimatter15/splat web viewer (Kevin Kwok, 2023;
// layout from its convert.py and main.js), also read by SuperSplat and
// Babylon.js. No header; 32 bytes per splat, little-endian:
//   bytes  0..11  position x y z                  3 x float32
//   bytes 12..23  scale (standard deviations)      3 x float32, exp(log_scale)
//   bytes 24..27  colour R G B A                   4 x uint8
//                 RGB = round(255 clamp(0.5 + C0 f_dc, 0, 1)), C0 = 0.28209479
//                 A   = round(255 sigmoid(opacity_logit))
//   bytes 28..31  rotation w x y z                 4 x uint8
//                 round(clamp(128 q + 128, 0, 255)) of the unit quaternion q
// Only the degree-0 SH (base colour) is stored; higher degrees are dropped.
// convert.py truncates when quantising; SaveSplat rounds to nearest, which
// halves the error and decodes the same way ((b - 128) / 128, b / 255).
//
// Order: splats are sorted by descending importance
//   exp(log_scale_0 + log_scale_1 + log_scale_2) * sigmoid(opacity_logit)
// (ellipsoid volume times opacity), the rule of antimatter15/splat's
// convert.py (np.argsort(-exp(sum of scales) / (1 + exp(-opacity)))), so
// viewers that stream the file draw the largest, most opaque splats first.
// Ties keep the map's order.
#pragma once

#include <string>

#include "engine/gaussians.h"

namespace dypho {

// Writes `cloud` as .splat atomically. An empty cloud writes an empty file
// (zero splats). Throws InvalidInput for inconsistent arrays, non-finite
// values, a zero quaternion or a scale that over- or underflows float32.
void SaveSplat(const GaussianCloud& cloud, const std::string& path);

// Reads a .splat file (lossy inverse of SaveSplat): sh_coeffs = 1,
// log_scales = log(scale), opacity_logits = logit(A / 255) with A clamped to
// [0.5, 254.5] so that the logit stays finite, quats = (b - 128) / 128 (an
// all-128 rotation decodes to the identity), f_dc = (RGB / 255 - 0.5) / C0.
// Throws InvalidInput naming the file when it is missing, its size is not a
// multiple of 32, or a position or scale is non-finite or a scale is not
// positive (the message names the splat index).
GaussianCloud LoadSplat(const std::string& path);

}  // namespace dypho
