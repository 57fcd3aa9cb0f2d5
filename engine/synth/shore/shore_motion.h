// The camera boat's motion in the synthetic harbour: slow headway along the
// shore (+x), a gentle roll, pitch and heave of a small boat on a swell, and
// a slow yaw; the camera looks towards the shore (+y), a little upwards.
#pragma once

#include "engine/eval/trajectory.h"
#include "engine/synth/shore/shore_options.h"

namespace dypho::synth {

// world_from_cam (OpenCV camera: x right, y down, z forward) at time t [s]
// after frame 0; independent of the seed.
Rigid3d ShoreCameraPose(const ShoreSynthOptions& options, double t);

// The poses of every frame, with the options' timestamps.
Trajectory ShoreTrajectory(const ShoreSynthOptions& options);

}  // namespace dypho::synth
