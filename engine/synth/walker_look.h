// How a walker looks: the paint style of every face of every body part
// (shirt, trousers, skin, hair, face, shoes) and its size, drawn from a seed.
#pragma once

#include <array>
#include <cstdint>

#include "engine/synth/quad_renderer.h"
#include "engine/synth/texture.h"
#include "engine/synth/walker.h"

namespace dypho::synth {

struct WalkerLook {
  double scale;  // body size factor (WalkerBody)
  std::array<std::array<PaintStyle, kBoxFaces>, kNumWalkerParts> styles;  // [part][face]
};

// The look of walker k; deterministic in (k, seed).
WalkerLook MakeWalkerLook(int k, uint64_t seed);

}  // namespace dypho::synth
