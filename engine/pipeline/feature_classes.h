// Features per class of the synthetic harbour's exact masks (water/, sky/
// and masks/ beside rgb/, engine/synth/shore/shore_scene.h): how many of
// the tracker's extracted features fall on water, sky and moving things.
// Used by `dypho ablate --preset shore` and its tests.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "engine/dataset/dataset.h"

namespace dypho {

struct FeatureClassCounts {
  long frames = 0;    // frames the tracker extracted features on
  long features = 0;  // all extracted features
  long water = 0;     // on a water pixel (water/ mask 255)
  long sky = 0;       // on a sky pixel (sky/ mask 255)
  long dynamic = 0;   // on a pedestrian or the boat (masks/ 255)
  double PerFrame(long n) const { return frames > 0 ? static_cast<double>(n) / frames : 0.0; }
};

// True when the dataset folder has the harbour's class masks (water/ and sky/).
bool HasClassMasks(const Dataset& dataset);

// Counts features against the exact masks of `dataset` (which must outlive
// it). Throws InvalidInput naming the file when a mask is missing or has
// another size than the image.
class FeatureClassCounter {
 public:
  // `inner_px` > 0: a feature counts for water or sky only when every pixel
  // within inner_px of it (a square window) is of that class, i.e. it is
  // not on the class boundary (where a corner on a skyline sits on sky).
  explicit FeatureClassCounter(const Dataset& dataset, int inner_px = 0);
  // Adds frame `index`'s features [px, input image; pixel centres at integers].
  void Add(size_t index, const std::vector<Eigen::Vector2f>& pixels);
  const FeatureClassCounts& counts() const { return counts_; }
  // A PipelineHooks::on_features that calls Add.
  std::function<void(size_t, const std::vector<Eigen::Vector2f>&)> Hook();

 private:
  const Dataset& dataset_;
  int inner_px_ = 0;
  FeatureClassCounts counts_;
};

}  // namespace dypho
