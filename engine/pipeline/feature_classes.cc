#include "engine/pipeline/feature_classes.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "common/check.h"
#include "engine/io/image_io.h"

namespace dypho {
namespace {
namespace fs = std::filesystem;

ImageU8 ReadClassMask(const std::string& path, const Camera& camera) {
  DYPHO_CHECK_INPUT(fs::is_regular_file(path)) << path << ": class mask not found";
  ImageU8 mask = ReadGray8(path);
  DYPHO_CHECK_INPUT(mask.width() == camera.width && mask.height() == camera.height)
      << path << ": class mask is " << mask.width() << "x" << mask.height() << ", the images " << camera.width << "x"
      << camera.height;
  return mask;
}

}  // namespace

bool HasClassMasks(const Dataset& dataset) {
  return fs::is_directory(fs::path(dataset.folder()) / "water") && fs::is_directory(fs::path(dataset.folder()) / "sky");
}

// Whether every pixel within r of (u, v), clipped to the image, is set.
static bool Inside(const ImageU8& mask, int u, int v, int r) {
  for (int y = std::max(0, v - r); y <= std::min(mask.height() - 1, v + r); ++y)
    for (int x = std::max(0, u - r); x <= std::min(mask.width() - 1, u + r); ++x)
      if (mask.at(x, y) == 0) return false;
  return true;
}

FeatureClassCounter::FeatureClassCounter(const Dataset& dataset, int inner_px)
    : dataset_(dataset), inner_px_(inner_px) {
  DYPHO_CHECK_INPUT(inner_px >= 0) << "feature class counter: inner_px " << inner_px << " is negative";
  DYPHO_CHECK_INPUT(HasClassMasks(dataset)) << dataset.folder() << ": no water/ and sky/ class masks";
}

void FeatureClassCounter::Add(size_t index, const std::vector<Eigen::Vector2f>& pixels) {
  const FrameInfo& info = dataset_.info(index);
  const std::string file = fs::path(info.rgb_path).filename().string();
  const fs::path root(dataset_.folder());
  const Camera& cam = dataset_.camera();
  const ImageU8 water = ReadClassMask((root / "water" / file).string(), cam);
  const ImageU8 sky = ReadClassMask((root / "sky" / file).string(), cam);
  const ImageU8 dynamic = ReadClassMask((root / "masks" / file).string(), cam);
  ++counts_.frames;
  for (const Eigen::Vector2f& p : pixels) {
    ++counts_.features;
    const int u = static_cast<int>(std::lround(p.x())), v = static_cast<int>(std::lround(p.y()));
    if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
    counts_.water += Inside(water, u, v, inner_px_);
    counts_.sky += Inside(sky, u, v, inner_px_);
    counts_.dynamic += dynamic.at(u, v) != 0;
  }
}

std::function<void(size_t, const std::vector<Eigen::Vector2f>&)> FeatureClassCounter::Hook() {
  return [this](size_t index, const std::vector<Eigen::Vector2f>& pixels) { Add(index, pixels); };
}

}  // namespace dypho
