#include "engine/synth/shore/shore_movers.h"

#include <cmath>

#include <Eigen/Geometry>

#include "engine/synth/shore/shore_layout.h"

namespace dypho::synth {

WalkRegion PromenadeRegion() {
  WalkRegion region;
  region.y_near = kQuayY + 1.2;
  region.y_far = kQuayY + 3.8;
  region.y_camera = 0.0;
  region.x_max = 9.0;
  return region;
}

std::vector<WalkerPlan> PlanPedestrians(const ShoreSynthOptions& options) {
  std::vector<WalkerPlan> plans;
  const double duration = (options.frames - 1) / options.fps;
  for (int k = 0; k < options.num_pedestrians; ++k) {
    plans.emplace_back(k, options.seed, PromenadeRegion(), duration, 1.2);
  }
  return plans;
}

std::array<Rigid3d, kNumWalkerParts> PedestrianPartPoses(const WalkerBody& body, const WalkerState& state) {
  std::array<Rigid3d, kNumWalkerParts> poses = WalkerPartPoses(body, state);
  for (Rigid3d& p : poses) p.translation.z() += kPromenadeZ;
  return poses;
}

std::array<BoatPart, kBoatParts> BoatPartsAt(const ShoreSynthOptions& options, double t) {
  const double x = -11.0 + options.boat_speed * t;
  const double heave = 0.05 * std::sin(2.0 * M_PI * 0.4 * t);
  const double roll = 0.03 * std::sin(2.0 * M_PI * 0.3 * t + 1.0);
  const Rigid3d world_from_boat(Eigen::Quaterniond(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX())),
                                Eigen::Vector3d(x, kBoatY, heave));
  std::array<BoatPart, kBoatParts> parts;
  // The hull reaches 0.3 m below the water line (hidden by the water).
  parts[0].size = Eigen::Vector3d(6.0, 2.2, 1.1);
  parts[0].world_from_box = world_from_boat * Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0.25));
  parts[1].size = Eigen::Vector3d(2.4, 1.7, 1.2);
  parts[1].world_from_box = world_from_boat * Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.6, 0, 1.4));
  return parts;
}

}  // namespace dypho::synth
