// Re-timing a depth image: RGB-D sensors such as the Kinect v1 of the TUM
// sequences do not capture colour and depth at the same instant (the TUM
// associations pair them up to 20 ms apart; in tum_fr1_rpy_head250 174 of 250
// pairs differ by more than 5 ms). Under fast rotation the depth then lies
// beside the colour it belongs to, so it is moved to the colour image's pose:
// every depth pixel is unprojected with the camera at the depth timestamp and
// projected into the camera at the colour timestamp (nearest pixel, nearest
// surface wins; one-pixel cracks between readings of the same surface are
// closed). Pixels nothing lands on read 0 (no depth).
#pragma once

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"

namespace dypho {

// `depth` [m] is an undistorted image of `camera` (pinhole) seen from the
// source pose; `target_from_source` maps source camera points to the target
// camera. Throws InvalidInput when the sizes disagree.
ImageF WarpDepth(const ImageF& depth, const Camera& camera, const Rigid3d& target_from_source);

}  // namespace dypho
