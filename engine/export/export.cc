#include "engine/export/export.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "common/check.h"
#include "engine/export/gltf.h"
#include "engine/export/ply.h"
#include "engine/export/splat.h"
#include "engine/export/spz.h"

namespace dypho {

MapFormat MapFormatFromPath(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".ply") return MapFormat::kPly;
  if (ext == ".splat") return MapFormat::kSplat;
  if (ext == ".glb") return MapFormat::kGlb;
  if (ext == ".gltf") return MapFormat::kGltf;
  if (ext == ".spz") return MapFormat::kSpz;
  DYPHO_CHECK_INPUT(false) << path << ": unknown map format '" << ext
                           << "' (expected .ply, .splat, .spz, .glb or .gltf)";
  return MapFormat::kPly;
}

void SaveMap(const GaussianCloud& cloud, const std::string& path) {
  switch (MapFormatFromPath(path)) {
    case MapFormat::kPly:
      SavePly(cloud, path);
      return;
    case MapFormat::kSplat:
      SaveSplat(cloud, path);
      return;
    case MapFormat::kGlb:
    case MapFormat::kGltf:
      SaveGltf(cloud, path);
      return;
    case MapFormat::kSpz:
      SaveSpz(cloud, path);
      return;
  }
}

GaussianCloud LoadMap(const std::string& path) {
  switch (MapFormatFromPath(path)) {
    case MapFormat::kPly:
      return LoadPly(path);
    case MapFormat::kSplat:
      return LoadSplat(path);
    case MapFormat::kGlb:
    case MapFormat::kGltf:
      return LoadGltf(path);
    case MapFormat::kSpz:
      return LoadSpz(path);
  }
  return GaussianCloud();
}

}  // namespace dypho
