#include "engine/synth/walker.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "engine/synth/random.h"

namespace dypho::synth {
namespace {

using Eigen::AngleAxisd;
using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;

// Unscaled proportions of a 1.75 m figure [m].
constexpr double kThigh = 0.44, kShin = 0.43, kFootHeight = 0.07, kHipHalfWidth = 0.1;
constexpr double kUpperArm = 0.30, kLowerArm = 0.33, kShoulderY = 0.255, kShoulderZ = 0.47;
// Gait amplitudes [rad] at full speed.
constexpr double kHipSwing = 0.42, kKneeBend = 0.9, kArmSwing = 0.25;

Matrix3d Rx(double a) { return AngleAxisd(a, Vector3d::UnitX()).toRotationMatrix(); }
Matrix3d Ry(double a) { return AngleAxisd(a, Vector3d::UnitY()).toRotationMatrix(); }

double WrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }
double Smoothstep(double x) {
  x = std::min(1.0, std::max(0.0, x));
  return x * x * (3.0 - 2.0 * x);
}

struct PartPose {
  Matrix3d rotation;
  Vector3d centre;
};

}  // namespace

WalkerBody::WalkerBody(double s) : scale(s) {
  size[kTorso] = Vector3d(0.22, 0.40, 0.56) * s;
  size[kNeck] = Vector3d(0.09, 0.09, 0.08) * s;
  size[kHead] = Vector3d(0.21, 0.18, 0.24) * s;
  size[kUpperArmLeft] = size[kUpperArmRight] = Vector3d(0.09, 0.09, kUpperArm) * s;
  size[kLowerArmLeft] = size[kLowerArmRight] = Vector3d(0.08, 0.08, kLowerArm) * s;
  size[kThighLeft] = size[kThighRight] = Vector3d(0.15, 0.15, kThigh) * s;
  size[kShinLeft] = size[kShinRight] = Vector3d(0.12, 0.12, kShin) * s;
  size[kFootLeft] = size[kFootRight] = Vector3d(0.26, 0.10, kFootHeight) * s;
}

double WalkRegion::XHalf(double y) const {
  // Half the horizontal field of view of the default camera is 31.4 deg;
  // 34 deg plus a margin takes walkers just out of the view at the sides.
  return std::min(x_max, 0.45 + std::max(0.0, y - y_camera) * std::tan(34.0 * M_PI / 180.0));
}

Vector2d WalkRegion::Map(double a, double b) const {
  const double y = y_near + b * (y_far - y_near);
  return Vector2d((2.0 * a - 1.0) * XHalf(y), y);
}

WalkerPlan::WalkerPlan(int index, uint64_t seed, const WalkRegion& region, double duration,
                       double cruise_speed) {
  Rng rng(Hash(seed, 0x3a1c, static_cast<uint64_t>(index)));
  cruise_speed_ = cruise_speed * rng.Uniform(0.85, 1.15);
  const double a0 = rng.Uniform(0.3, 0.7);
  const double b0 = rng.Uniform(0.0, 1.0);
  Vector2d pos = region.Map(a0, index == 0 ? 0.25 * b0 : b0);
  bool go_left = rng.Bernoulli(0.5);
  double t = -rng.Uniform(0.0, 0.8);  // start mid-action
  double heading = 0.0;
  double distance = 0.0;
  bool first = true;
  for (int step = 0; t < duration + 1.0 && step < 100000; ++step) {
    // A fixed number of draws per step keeps the sequence of draws the same
    // for every region.
    const double r_mid = rng.Uniform(), a_side = rng.Uniform(), a_mid = rng.Uniform();
    const double b = rng.Uniform(), stand_draw = rng.Uniform(), stand_time = rng.Uniform(0.4, 2.0);
    double a;
    if (r_mid < 0.25) {
      a = 0.35 + 0.3 * a_mid;  // stop in the middle of the view
    } else {
      a = go_left ? 0.12 * a_side : 1.0 - 0.12 * a_side;
      go_left = !go_left;
    }
    // Walker 0 starts with a crossing close to the camera.
    const Vector2d target = region.Map(a, (index == 0 && first) ? 0.25 * b : b);
    const Vector2d delta = target - pos;
    const double length = delta.norm();
    if (length < 0.3) continue;
    const double new_heading = std::atan2(delta.y(), delta.x());
    if (first) heading = new_heading;
    const double turn = WrapAngle(new_heading - heading);
    if (std::abs(turn) > 0.03) {
      const double turn_time = 0.2 + std::abs(turn) / 1.6;
      segments_.push_back({Kind::kTurn, t, t + turn_time, pos, pos, heading, heading + turn, distance});
      t += turn_time;
    }
    const double walk_time = WalkDuration(length);
    segments_.push_back({Kind::kWalk, t, t + walk_time, pos, target, new_heading, new_heading, distance});
    t += walk_time;
    distance += length;
    pos = target;
    heading = new_heading;
    if (stand_draw < 0.55) {
      segments_.push_back({Kind::kStand, t, t + stand_time, pos, pos, heading, heading, distance});
      t += stand_time;
    }
    first = false;
  }
  DYPHO_CHECK(!segments_.empty()) << "walker plan is empty";
}

double WalkerPlan::WalkDuration(double length) const {
  const double v = cruise_speed_, a = accel_;
  if (length >= v * v / a) return length / v + v / a;
  return 2.0 * std::sqrt(length / a);
}

void WalkerPlan::WalkProfile(double length, double tau, double* distance, double* speed) const {
  // Trapezoidal speed: accelerate at a, cruise at v, decelerate at a (or a
  // triangle when the walk is too short to reach v).
  const double a = accel_;
  const double total = WalkDuration(length);
  tau = std::min(std::max(tau, 0.0), total);
  const double v_peak = std::min(cruise_speed_, std::sqrt(length * a));
  const double ramp = v_peak / a;
  if (tau < ramp) {
    *distance = 0.5 * a * tau * tau;
    *speed = a * tau;
  } else if (tau > total - ramp) {
    const double left = total - tau;
    *distance = length - 0.5 * a * left * left;
    *speed = a * left;
  } else {
    *distance = 0.5 * a * ramp * ramp + v_peak * (tau - ramp);
    *speed = v_peak;
  }
}

WalkerState WalkerPlan::StateAt(double t) const {
  WalkerState state;
  // The segment that contains t (the first before its start, the last after its end).
  auto it = std::upper_bound(segments_.begin(), segments_.end(), t,
                             [](double value, const Segment& s) { return value < s.t0; });
  const Segment& seg = it == segments_.begin() ? segments_.front() : *(it - 1);
  const double tau = std::min(std::max(t - seg.t0, 0.0), seg.t1 - seg.t0);
  double walked = seg.distance0;
  switch (seg.kind) {
    case Kind::kWalk: {
      const double length = (seg.to - seg.from).norm();
      double d = 0.0, v = 0.0;
      WalkProfile(length, tau, &d, &v);
      state.position = seg.from + (seg.to - seg.from) * (d / length);
      state.heading = seg.heading0;
      state.gait = std::min(1.0, v / cruise_speed_);
      walked += d;
      break;
    }
    case Kind::kTurn: {
      state.position = seg.from;
      state.heading = seg.heading0 + (seg.heading1 - seg.heading0) * Smoothstep(tau / (seg.t1 - seg.t0));
      break;
    }
    case Kind::kStand: {
      state.position = seg.from;
      state.heading = seg.heading0;
      break;
    }
  }
  state.gait_phase = 2.0 * M_PI * walked / stride_;
  return state;
}

std::array<Rigid3d, kNumWalkerParts> WalkerPartPoses(const WalkerBody& body, const WalkerState& state) {
  const double s = body.scale, g = state.gait, phi = state.gait_phase;
  const double hip_z = (kThigh + kShin + kFootHeight) * s;
  std::array<PartPose, kNumWalkerParts> local;

  // Legs: the hip swings the thigh forward by alpha, the knee bends back by
  // beta during the swing phase (when the leg moves forward).
  auto leg = [&](double side, double alpha, double beta, int thigh, int shin, int foot) {
    const Vector3d hip(0.0, side * kHipHalfWidth * s, hip_z);
    const Matrix3d r_thigh = Ry(-alpha);
    const Vector3d knee = hip + r_thigh * Vector3d(0, 0, -kThigh * s);
    const Matrix3d r_shin = r_thigh * Ry(beta);
    const Vector3d ankle = knee + r_shin * Vector3d(0, 0, -kShin * s);
    local[thigh] = {r_thigh, hip + r_thigh * Vector3d(0, 0, -0.5 * kThigh * s)};
    local[shin] = {r_shin, knee + r_shin * Vector3d(0, 0, -0.5 * kShin * s)};
    local[foot] = {r_shin, ankle + r_shin * Vector3d(0.06 * s, 0, -0.5 * kFootHeight * s)};
  };
  const double swing = kHipSwing * g * std::sin(phi);
  leg(1.0, swing, 0.05 + kKneeBend * g * std::max(0.0, std::cos(phi)), kThighLeft, kShinLeft, kFootLeft);
  leg(-1.0, -swing, 0.05 + kKneeBend * g * std::max(0.0, -std::cos(phi)), kThighRight, kShinRight,
      kFootRight);

  // Arms swing against the leg of the same side; elbows bend more when walking.
  auto arm = [&](double side, double gamma, int upper, int lower) {
    const Vector3d shoulder(0.0, side * kShoulderY * s, hip_z + kShoulderZ * s);
    const Matrix3d r_upper = Rx(side * 0.08) * Ry(-gamma);
    const Vector3d elbow = shoulder + r_upper * Vector3d(0, 0, -kUpperArm * s);
    const Matrix3d r_lower = r_upper * Ry(-(0.25 + 0.25 * g));
    local[upper] = {r_upper, shoulder + r_upper * Vector3d(0, 0, -0.5 * kUpperArm * s)};
    local[lower] = {r_lower, elbow + r_lower * Vector3d(0, 0, -0.5 * kLowerArm * s)};
  };
  const double arm_swing = kArmSwing * g * std::sin(phi);
  arm(1.0, -arm_swing, kUpperArmLeft, kLowerArmLeft);
  arm(-1.0, arm_swing, kUpperArmRight, kLowerArmRight);

  local[kTorso] = {Matrix3d::Identity(), Vector3d(0, 0, hip_z + 0.22 * s)};
  local[kNeck] = {Matrix3d::Identity(), Vector3d(0, 0, hip_z + 0.54 * s)};
  local[kHead] = {Matrix3d::Identity(), Vector3d(0.01 * s, 0, hip_z + 0.70 * s)};

  // Lower the body until the lowest foot corner touches the floor.
  double lowest = 1e9;
  for (int foot : {kFootLeft, kFootRight}) {
    const Vector3d half = 0.5 * body.size[foot];
    for (int corner = 0; corner < 8; ++corner) {
      const Vector3d c((corner & 1) ? half.x() : -half.x(), (corner & 2) ? half.y() : -half.y(),
                       (corner & 4) ? half.z() : -half.z());
      lowest = std::min(lowest, (local[foot].centre + local[foot].rotation * c).z());
    }
  }
  const Rigid3d world_from_walker(Eigen::Quaterniond(AngleAxisd(state.heading, Vector3d::UnitZ())),
                                  Vector3d(state.position.x(), state.position.y(), -lowest));
  std::array<Rigid3d, kNumWalkerParts> out;
  for (int p = 0; p < kNumWalkerParts; ++p) {
    out[p] = world_from_walker * Rigid3d(Eigen::Quaterniond(local[p].rotation), local[p].centre);
  }
  return out;
}

}  // namespace dypho::synth
