// What moves in the synthetic harbour: pedestrians on the promenade (the
// indoor generator's walkers, engine/synth/walker.h, lifted onto it) and a
// boat passing along +x between the camera and the shore.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "common/rigid3.h"
#include "engine/synth/shore/shore_options.h"
#include "engine/synth/walker.h"

namespace dypho::synth {

// The promenade strip the pedestrians use (behind the railing, in front of the trees).
WalkRegion PromenadeRegion();

// The pedestrians' plans for the whole sequence.
std::vector<WalkerPlan> PlanPedestrians(const ShoreSynthOptions& options);

// world_from_part of every part of a pedestrian, standing on the promenade.
std::array<Rigid3d, kNumWalkerParts> PedestrianPartPoses(const WalkerBody& body, const WalkerState& state);

// The passing boat's parts: 0 = hull, 1 = cabin.
constexpr int kBoatParts = 2;
struct BoatPart {
  Rigid3d world_from_box;
  Eigen::Vector3d size;  // [m]
};
// The boat at time t [s] after frame 0 (bobbing a little on the swell).
std::array<BoatPart, kBoatParts> BoatPartsAt(const ShoreSynthOptions& options, double t);

}  // namespace dypho::synth
