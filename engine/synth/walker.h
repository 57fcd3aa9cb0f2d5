// Walkers: articulated box figures (torso, neck, head, upper and lower arms,
// thighs, shins, feet) that walk between waypoints across the camera's view,
// stop, turn in place and walk on. Limbs swing with a gait phase tied to the
// distance walked, so feet do not slide much; the body is lowered so that the
// lowest foot touches the floor.
//
// Walker frame: x forward, y left, z up, origin on the floor below the hips.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "common/rigid3.h"

namespace dypho::synth {

enum WalkerPart {
  kTorso,
  kNeck,
  kHead,
  kUpperArmLeft,
  kLowerArmLeft,
  kUpperArmRight,
  kLowerArmRight,
  kThighLeft,
  kShinLeft,
  kFootLeft,
  kThighRight,
  kShinRight,
  kFootRight,
  kNumWalkerParts,
};

// Body proportions of a 1.75 m figure times `scale`.
struct WalkerBody {
  double scale = 1.0;
  // Box size of each part [m] (x forward, y left, z along the limb).
  std::array<Eigen::Vector3d, kNumWalkerParts> size;
  explicit WalkerBody(double scale = 1.0);
};

// Pose of a walker at one instant.
struct WalkerState {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  // on the floor [m, world x y]
  double heading = 0.0;                                // direction of x about world z [rad]
  double gait_phase = 0.0;                             // [rad], 2 pi per stride (two steps)
  double gait = 0.0;  // limb swing amplitude in [0, 1] (speed / cruise speed)
};

// The floor area the walkers use: y in [y_near, y_far]; at a given y, x in
// [-XHalf(y), XHalf(y)], which widens with the distance from the camera
// (at y_camera) so that walkers leave the view at the sides.
struct WalkRegion {
  double y_near = 0.0;     // [m]
  double y_far = 2.35;     // [m]
  double y_camera = -1.3;  // [m]
  double x_max = 1.85;     // [m]
  double XHalf(double y) const;
  // A point from normalised coordinates a (left to right) and b (near to far) in [0, 1].
  Eigen::Vector2d Map(double a, double b) const;
};

// A walker's timeline: walk, stand and turn segments covering
// [start time, duration].
class WalkerPlan {
 public:
  // Plans walker `index` for `duration` seconds; deterministic in (seed,
  // index). Random draws do not depend on the region, so plans for two
  // regions differ only by the mapping of the same normalised waypoints.
  WalkerPlan(int index, uint64_t seed, const WalkRegion& region, double duration, double cruise_speed);

  WalkerState StateAt(double t) const;
  double cruise_speed() const { return cruise_speed_; }
  double stride() const { return stride_; }

 private:
  enum class Kind { kWalk, kStand, kTurn };
  struct Segment {
    Kind kind;
    double t0, t1;             // [s]
    Eigen::Vector2d from, to;  // [m]
    double heading0, heading1;
    double distance0;  // distance walked before this segment [m]
  };
  // Distance covered and speed at time tau into a walk of length L.
  void WalkProfile(double length, double tau, double* distance, double* speed) const;
  double WalkDuration(double length) const;

  std::vector<Segment> segments_;
  double cruise_speed_;
  double accel_ = 1.2;   // [m/s^2]
  double stride_ = 1.3;  // [m] per gait cycle
};

// world_from_part (box centre) of every part at `state`.
std::array<Rigid3d, kNumWalkerParts> WalkerPartPoses(const WalkerBody& body, const WalkerState& state);

}  // namespace dypho::synth
