// OrbExtractorOptions::IsValid and the relaxed-threshold formula of
// OrbExtractor (tracker/orb_extractor.h).
#include "tracker/orb_extractor.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

namespace dypho {

bool OrbExtractorOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  if (num_features < 1) {
    e << "num_features must be >= 1 (got " << num_features << ")";
  } else if (num_levels < 1 || num_levels > 16) {
    e << "num_levels must be in 1..16 (got " << num_levels << ")";
  } else if (!(scale_factor > 1.0 && scale_factor <= 2.0)) {
    e << "scale_factor must be in (1, 2] (got " << scale_factor << ")";
  } else if (cell_size < 8) {
    e << "cell_size must be >= 8 px (got " << cell_size << ")";
  } else if (initial_fast_threshold < 1 || initial_fast_threshold > 255) {
    e << "initial_fast_threshold must be in 1..255 (got " << initial_fast_threshold << ")";
  } else if (fallback_fast_threshold < 1 || fallback_fast_threshold > initial_fast_threshold) {
    e << "fallback_fast_threshold must be in 1..initial_fast_threshold (got " << fallback_fast_threshold
      << ")";
  } else if (min_corners_per_cell < 1) {
    e << "min_corners_per_cell must be >= 1 (got " << min_corners_per_cell << ")";
  } else if (!(adaptive_exponent >= 0.0 && adaptive_exponent <= 4.0)) {
    e << "adaptive_exponent must be in [0, 4] (got " << adaptive_exponent << ")";
  } else if (min_fast_threshold < 1 || min_fast_threshold > fallback_fast_threshold) {
    e << "min_fast_threshold must be in 1..fallback_fast_threshold (got " << min_fast_threshold << ")";
  } else if (!(min_static_fraction >= 0.0 && min_static_fraction < 1.0)) {
    e << "min_static_fraction must be in [0, 1) (got " << min_static_fraction << ")";
  } else if (mask_dilation < 0 || mask_dilation > 50) {
    e << "mask_dilation must be in 0..50 px (got " << mask_dilation << ")";
  } else {
    return true;
  }
  if (error != nullptr) *error = "OrbExtractorOptions." + e.str();
  return false;
}

int OrbExtractor::AdaptiveThreshold(int threshold, double global_static_fraction,
                                    double cell_static_fraction, double exponent, int min_threshold) {
  const double support = std::clamp(global_static_fraction * cell_static_fraction, 0.0, 1.0);
  const double relaxed = threshold * std::pow(support, exponent);
  return std::max(min_threshold, static_cast<int>(std::lround(relaxed)));
}

}  // namespace dypho
