#include "engine/stereo/pair_folder.h"

#include <algorithm>
#include <filesystem>

#include "common/check.h"

namespace dypho::stereo {
namespace fs = std::filesystem;

std::vector<ImagePair> ListImagePairs(const std::string& folder) {
  if (!fs::is_directory(folder)) throw InvalidInput(folder + ": not a folder");
  static const char* kLayouts[][2] = {{"image_0", "image_1"}, {"image_2", "image_3"},
                                      {"mav0/cam0/data", "mav0/cam1/data"}, {"left", "right"}};
  for (const auto& layout : kLayouts) {
    const fs::path left_dir = fs::path(folder) / layout[0], right_dir = fs::path(folder) / layout[1];
    if (!fs::is_directory(left_dir)) continue;
    if (!fs::is_directory(right_dir))
      throw InvalidInput(right_dir.string() + ": missing (the right images of " + left_dir.string() + ")");
    std::vector<ImagePair> pairs;
    for (const auto& entry : fs::directory_iterator(left_dir)) {
      const std::string ext = entry.path().extension().string();
      if (!entry.is_regular_file() || (ext != ".png" && ext != ".jpg" && ext != ".ppm" && ext != ".pgm")) continue;
      const fs::path right = right_dir / entry.path().filename();
      if (!fs::exists(right))
        throw InvalidInput(right.string() + ": missing right image for " + entry.path().string());
      pairs.push_back({entry.path().filename().string(), entry.path().string(), right.string()});
    }
    std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
    if (pairs.empty()) throw InvalidInput(left_dir.string() + ": no images (.png, .jpg, .ppm, .pgm)");
    return pairs;
  }
  throw InvalidInput(folder + ": no stereo layout found (image_0/ + image_1/, image_2/ + image_3/, "
                     "mav0/cam0/data/ + mav0/cam1/data/, or left/ + right/)");
}

}  // namespace dypho::stereo
