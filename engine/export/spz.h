// The .spz format (Niantic's compressed Gaussian-splat format, "Splat Zip";
// specification in the README and docs of github.com/nianticlabs/spz, MIT).
// Written here from that specification with zlib; no code of the reference
// library is used.
//
// Container: one gzip stream (RFC 1952) holding a 16-byte little-endian
// header, then the attributes as separate arrays (structure of arrays), in
// this order:
//   header    uint32 magic 0x5053474e ("NGSP"), uint32 version (2 or 3),
//             uint32 num_points, uint8 sh_degree (0..3), uint8 fractional_bits,
//             uint8 flags (0x1 antialiased, 0x2 extensions follow), uint8 reserved (0)
//   positions N x 3 x int24 (little-endian, two's complement) fixed point:
//             x = value / 2^fractional_bits
//   alphas    N x uint8: round(255 sigmoid(opacity_logit))
//   colours   N x 3 x uint8: round(255 (0.15 f_dc + 0.5)) (the format's colour
//             scale 0.15 keeps base colours somewhat outside [0, 1] that higher
//             SH bands bring back)
//   scales    N x 3 x uint8: round(16 (log_scale + 10))
//   rotations version 3: N x uint32, "smallest three": the index (0..3, in
//             x y z w order) of the largest component of the unit quaternion
//             in bits 30-31, then for the other three components in index
//             order, 10 bits each from bit 20 down: a sign bit (bit 9) and a
//             9-bit magnitude round(511 |q_i| sqrt(2)) (|q_i| <= 1/sqrt(2));
//             the quaternion is negated first so the largest component is
//             positive, and the decoder restores it as sqrt(1 - sum of squares).
//             version 2: N x 3 x uint8: x y z of the unit quaternion negated so
//             that w >= 0, round(127.5 q + 127.5); w = sqrt(1 - x^2 - y^2 - z^2).
//   SH        N x (K - 1) x 3 x uint8 (K = (degree + 1)^2; the DC term is the
//             colour above), coefficient-major with the colour channel inner
//             (dypho's own [N, K, 3] layout without coefficient 0); byte
//             b = 128 + 128 x rounded to a multiple of 8 for degree-1
//             coefficients (5 bits) and of 16 for degrees 2 and 3 (4 bits),
//             the reference library's default precision, clamped to 0..255;
//             decoded as (b - 128) / 128.
//
// Written: version 3 by default (SpzOptions::version = 2 for viewers that
// only read version 2), flags 0, fractional_bits 12 (the reference
// library's choice, 1/4096 m), fewer when a coordinate would not fit in 24
// bits (|x| >= 2048 m); a map wider than 2^23 m is an error.
//
// Coordinates: the format's frame is right-up-back (RUB, OpenGL/three.js);
// dypho's world frame has the camera convention right-down-front (RDF, as the
// 3DGS PLY), so the writer rotates the map by 180 degrees about x (the same
// change as the glTF exporter, engine/export/gltf.h): position (x, -y, -z),
// quaternion (w, x, -y, -z), SH coefficient k times s_k = (-1)^(degree of
// Y_k in y and z). The reader undoes it.
//
// Quantisation error of a round trip SaveSpz -> LoadSpz (every bound is
// checked by tests/export_spz_test.cc):
//   position      <= 2^-(fractional_bits + 1) per axis (0.122 mm at 12 bits)
//   opacity       |sigmoid(logit') - sigmoid(logit)| <= 0.5 / 255
//   f_dc          <= 0.5 / (255 * 0.15) = 0.0131 within |f_dc| <= 3.33
//                 (RGB 0.5 + C0 f_dc within 0.0037); clamped outside
//   log_scale     <= 1 / 32 (scale within 3.2 %) within [-10, 5.94]
//                 (scales 45 um .. 379 m); clamped outside
//   rotation      version 3: <= 0.3 degrees (angle between the rotations;
//                 each stored component within 0.0007, the derived largest
//                 within 3x that; 0.21 degrees measured on 4000 random
//                 rotations); version 2: each of x y z within 1/255 and w
//                 derived, so the error grows as w -> 0: <= 1.6 degrees where
//                 |w| >= 0.5 (1.27 measured), up to about 13 degrees for
//                 rotations near 180 degrees (w near 0)
//   SH (k >= 1)   <= 1/32 (degree 1), 1/16 (degrees 2 and 3) within [-1, 1];
//                 clamped outside
// The loader returns opacity logits of alphas clamped to [0.5, 254.5] / 255
// (finite logits, within the bound above) and unit quaternions.
//
// Checked by hand once against a third-party implementation, the npm
// package spz-js 1.2.5 (a version-2 reader and writer): it decodes a
// version-2 file written here to the same values (in the format's frame),
// and LoadSpz reads its re-encoding of them to the same map.
//
// Not read: version 1 (float16 positions, never released by Niantic), the
// uncompressed "NGSP" container of newer library versions, files with
// extensions (flag 0x2: an extension may change how SH is decoded), SH
// degree 4. Each is a clear InvalidInput naming the file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "engine/gaussians.h"

namespace dypho {

struct SpzOptions {
  int version = 3;           // format version written: 3 (smallest-three rotations) or 2
  int compression_level = 6; // zlib deflate level 1 (fastest) .. 9 (smallest)

  // False (and `error` names the field) when a value is out of range.
  bool IsValid(std::string* error) const;
};

// Writes `cloud` as .spz atomically (temporary file, then rename). An empty
// cloud writes a valid file with zero points. Throws InvalidInput for invalid
// options, inconsistent arrays, non-finite values, a zero quaternion or a
// map too large for 24-bit positions.
void SaveSpz(const GaussianCloud& cloud, const std::string& path, const SpzOptions& options = SpzOptions());

// Reads a .spz file (versions 2 and 3; the inverse of SaveSpz within the
// quantisation error above). Throws InvalidInput naming the file for a missing
// file, data that is not gzip, corrupt or truncated compressed data, a bad
// magic, version, SH degree, flag or reserved byte, and a decompressed size
// other than the header's point count implies.
GaussianCloud LoadSpz(const std::string& path);

// The same in memory: the bytes of a .spz file. `what` names the source in
// error messages.
std::vector<uint8_t> EncodeSpz(const GaussianCloud& cloud, const SpzOptions& options, const std::string& what);
GaussianCloud DecodeSpz(const uint8_t* data, size_t size, const std::string& what);

}  // namespace dypho
