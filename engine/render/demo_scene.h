// A built-in demo scene of Gaussians (no data files needed): a checkered
// floor of flat splats, three spheres made of surface splats (one with
// view-dependent SH colour) and a ring of translucent blobs.
#pragma once

#include "common/camera.h"
#include "common/rigid3.h"
#include "engine/gaussians.h"

namespace dypho {

GaussianCloud MakeDemoScene();
// A camera looking at the scene from (0, -1.2, -3.2) (y is down).
Rigid3d DemoCamFromWorld(double orbit_angle = 0.0);
Camera DemoCamera(int width = 640, int height = 480);

}  // namespace dypho
