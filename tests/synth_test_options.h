// Options shared by the synthetic-generator tests (synth_test.cc,
// synth_render_test.cc): a small sequence, and the walkers' share of a mask.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "common/image.h"
#include "engine/synth/synthetic_scene.h"

namespace dypho::synth_testing {

constexpr double kDeg = M_PI / 180.0;

inline SynthOptions SmallOptions(uint64_t seed = 1, int walkers = 2, SynthMotion motion = SynthMotion::kXyz,
                          int frames = 6) {
  SynthOptions o;
  o.width = 160;
  o.height = 120;
  o.frames = frames;
  o.seed = seed;
  o.num_walkers = walkers;
  o.motion = motion;
  return o;
}

inline double Coverage(const ImageU8& mask) {
  return static_cast<double>(std::count(mask.pixels().begin(), mask.pixels().end(), uint8_t{255})) /
         mask.pixels().size();
}

}  // namespace dypho::synth_testing
