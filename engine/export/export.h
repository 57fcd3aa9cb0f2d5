// One entry point for map files, choosing the format by the file extension
// (case-insensitive):
//   .ply    3DGS PLY (engine/export/ply.h), lossless
//   .splat  antimatter15 .splat (engine/export/splat.h), degree-0 colour, quantised
//   .spz    Niantic's compressed .spz, version 3 (engine/export/spz.h), quantised
//   .glb    glTF 2.0 binary with KHR_gaussian_splatting (engine/export/gltf.h)
//   .gltf   glTF 2.0 JSON with an embedded buffer (engine/export/gltf.h)
#pragma once

#include <string>

#include "engine/gaussians.h"

namespace dypho {

enum class MapFormat { kPly, kSplat, kGlb, kGltf, kSpz };

// The format for `path`; throws InvalidInput naming the file for another
// extension.
MapFormat MapFormatFromPath(const std::string& path);

// Writes `cloud` in the format of `path` (atomically).
void SaveMap(const GaussianCloud& cloud, const std::string& path);

// Reads a map in any of the formats above (a .splat, .spz or .glb/.gltf written by
// dypho loses what its format does not keep: see the format's header).
GaussianCloud LoadMap(const std::string& path);

}  // namespace dypho
