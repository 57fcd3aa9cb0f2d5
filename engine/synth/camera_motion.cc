#include "engine/synth/camera_motion.h"

#include <cmath>

#include "engine/synth/random.h"
#include "engine/synth/scene_layout.h"

namespace dypho {
namespace synth {
namespace {

using Eigen::AngleAxisd;
using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr double kDeg = M_PI / 180.0;

double Wave(double amplitude, double period, double phase, double t) {
  return amplitude * std::sin(2.0 * M_PI * t / period + phase);
}

// A small rotation in the camera frame: yaw about the camera's up (-y),
// pitch about x, roll about z [rad].
Quaterniond CameraYawPitchRoll(double yaw, double pitch, double roll) {
  return Quaterniond(AngleAxisd(yaw, -Vector3d::UnitY()) * AngleAxisd(pitch, Vector3d::UnitX()) *
                     AngleAxisd(roll, Vector3d::UnitZ()));
}

}  // namespace

Rigid3d LookAt(const Vector3d& eye, const Vector3d& target) {
  const Vector3d z = (target - eye).normalized();
  const Vector3d x = z.cross(Vector3d::UnitZ()).normalized();
  const Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return Rigid3d(Quaterniond(R), eye);
}

Vector3d HalfsphereCentre() {
  return CameraHome() + kHalfsphereForward * (LookTarget() - CameraHome()).normalized();
}

Vector3d LoopCentre() { return Vector3d(0.0, 0.4, CameraHome().z()); }

Rigid3d SynthCameraPose(SynthMotion motion, double t, uint64_t seed) {
  Rng rng(Hash(seed, 0xca3e7a));
  double phase[6];
  for (double& p : phase) p = rng.Uniform(0.0, 2.0 * M_PI);
  const Vector3d home = CameraHome();
  const Rigid3d base = LookAt(home, LookTarget());
  switch (motion) {
    case SynthMotion::kXyz: {
      // Like fr1/xyz: the camera slides along the three axes with its
      // orientation nearly fixed.
      const Vector3d p =
          home + Vector3d(Wave(kXyzAmplitude[0], 4.5, phase[0], t), Wave(kXyzAmplitude[1], 6.1, phase[1], t),
                          Wave(kXyzAmplitude[2], 5.3, phase[2], t));
      const Quaterniond r = CameraYawPitchRoll(Wave(kXyzRotationDeg * kDeg, 5.7, phase[3], t),
                                               Wave(kXyzRotationDeg * kDeg, 6.7, phase[4], t),
                                               Wave(kXyzRotationDeg * kDeg, 7.3, phase[5], t));
      return Rigid3d(base.rotation * r, p);
    }
    case SynthMotion::kRpy: {
      // Like fr1/rpy: rotations about the camera's own axes, a little shake.
      const Quaterniond r = CameraYawPitchRoll(Wave(kRpyAmplitudeDeg * kDeg, 5.0, phase[0], t),
                                               Wave(kRpyAmplitudeDeg * kDeg, 4.1, phase[1], t),
                                               Wave(kRpyAmplitudeDeg * kDeg, 6.3, phase[2], t));
      const Vector3d p =
          home + Vector3d(Wave(kRpyTranslation, 2.3, phase[3], t), Wave(kRpyTranslation, 2.9, phase[4], t),
                          Wave(kRpyTranslation, 3.7, phase[5], t));
      return Rigid3d(base.rotation * r, p);
    }
    case SynthMotion::kHalfsphere: {
      // Like fr3/walking_halfsphere: the camera travels over the back half of
      // a sphere (the half facing away from the target) and always looks at
      // the target. Polar angle from the back pole and azimuth vary slowly.
      const Vector3d centre = HalfsphereCentre();
      const Vector3d pole = (CameraHome() - LookTarget()).normalized();
      const Vector3d e1 = pole.cross(Vector3d::UnitZ()).normalized();
      const Vector3d e2 = pole.cross(e1);
      const double polar =
          kHalfsphereMaxPolarDeg * kDeg * (0.5 - 0.5 * std::cos(2.0 * M_PI * t / 12.0 + phase[0]));
      const double azimuth = phase[1] + 2.0 * M_PI * t / 20.0;
      const Vector3d dir =
          std::cos(polar) * pole + std::sin(polar) * (std::cos(azimuth) * e1 + std::sin(azimuth) * e2);
      return LookAt(centre + kHalfsphereRadius * dir, LookTarget());
    }
    case SynthMotion::kStatic: {
      // A tripod: fixed, with a barely visible jitter.
      const Vector3d p =
          home + Vector3d(Wave(kStaticJitter, 1.7, phase[0], t), Wave(kStaticJitter, 2.3, phase[1], t),
                          Wave(kStaticJitter, 1.9, phase[2], t));
      const Quaterniond r = CameraYawPitchRoll(Wave(kStaticJitterDeg * kDeg, 2.1, phase[3], t),
                                               Wave(kStaticJitterDeg * kDeg, 1.3, phase[4], t),
                                               Wave(kStaticJitterDeg * kDeg, 2.7, phase[5], t));
      return Rigid3d(base.rotation * r, p);
    }
    case SynthMotion::kLoop: {
      // Laps of a horizontal circle, looking outwards (radially) and a
      // little down, so the camera sweeps every wall and comes back to its
      // first view after each lap; the first view looks towards +y like the
      // other presets. No seed dependence: a lap closes exactly.
      const double angle = 0.5 * M_PI + 2.0 * M_PI * t / kLoopPeriod;
      const Vector3d radial(std::cos(angle), std::sin(angle), 0.0);
      const Vector3d eye = LoopCentre() + kLoopRadius * radial;
      return LookAt(eye, eye + radial - Vector3d(0.0, 0.0, std::tan(kLoopLookDown)));
    }
  }
  return base;
}

}  // namespace synth

Trajectory MakeSynthTrajectory(const SynthOptions& options) {
  options.Validate();
  Trajectory trajectory;
  for (int i = 0; i < options.frames; ++i) {
    trajectory.Add(options.Timestamp(i),
                   synth::SynthCameraPose(options.motion, i / options.fps, options.seed));
  }
  return trajectory;
}

}  // namespace dypho
