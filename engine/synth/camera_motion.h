// Camera trajectories of the synthetic sequences: smooth, deterministic
// functions of time shaped like the TUM RGB-D sequences of the same names.
// Poses are world_from_cam (x right, y down, z forward; world z up).
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "common/rigid3.h"
#include "engine/eval/trajectory.h"
#include "engine/synth/synth_options.h"

namespace dypho {

// One pose per frame at options.Timestamp(i).
Trajectory MakeSynthTrajectory(const SynthOptions& options);

namespace synth {

// A camera at `eye` looking at `target` with the world's +z up in the image
// (the camera's x axis horizontal). `target` must not be straight above or
// below `eye`.
Rigid3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target);

// Preset parameters (documented here so tests can check the shapes).
constexpr double kXyzAmplitude[3] = {0.25, 0.22, 0.18};  // translation along world x, y, z [m]
constexpr double kXyzRotationDeg = 3.0;                  // max of each small rotation [deg]
constexpr double kRpyAmplitudeDeg = 20.0;                // roll, pitch and yaw [deg]
constexpr double kRpyTranslation = 0.015;                // hand shake along each axis [m]
constexpr double kHalfsphereRadius = 1.0;                // [m]
constexpr double kHalfsphereMaxPolarDeg = 60.0;          // max angle from the sphere's back pole [deg]
constexpr double kHalfsphereForward = 0.6;               // sphere centre ahead of CameraHome() [m]
constexpr double kStaticJitter = 0.002;                  // translation jitter per axis [m]
constexpr double kStaticJitterDeg = 0.15;                // rotation jitter per axis [deg]
constexpr double kLoopRadius = 0.5;                      // [m] circle of the loop preset
constexpr double kLoopPeriod = 12.0;                     // [s] one lap (the pose repeats exactly)
constexpr double kLoopLookDown = 0.15;                   // [rad] the camera's downward tilt

// Centre of the halfsphere preset's sphere [m, world].
Eigen::Vector3d HalfsphereCentre();
// Centre of the loop preset's circle [m, world] (at the camera's height).
Eigen::Vector3d LoopCentre();

// world_from_cam of `motion` at time t [s] since the first frame; the seed
// picks the phases of the oscillations.
Rigid3d SynthCameraPose(SynthMotion motion, double t, uint64_t seed);

}  // namespace synth
}  // namespace dypho
