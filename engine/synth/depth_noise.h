// A Kinect-like depth sensor model for the synthetic sequences.
//
// - Axial noise (Nguyen, Izadi, Lovell 2012, "Modeling Kinect Sensor Noise
//   for Improved 3D Reconstruction and Tracking", 3DIMPVT):
//   sigma_z(z, theta) = 0.0012 + 0.0019 (z - 0.4)^2 [m], plus
//   0.0001 / sqrt(z) * theta^2 / (pi/2 - theta)^2 for theta > 60 deg, where
//   theta is the angle between the surface normal and the viewing ray.
// - Lateral noise near depth edges (same paper):
//   sigma_L(theta) = 0.8 + 0.035 theta / (pi/2 - theta) [px at fx = 525],
//   applied as a random shift of the pixel that is read, only within a few
//   pixels of a depth discontinuity, so edges become ragged while smooth
//   surfaces keep the axial model alone.
// - Holes: on the far side of depth discontinuities (high probability next
//   to the edge, lower further out) and a little on the near side; at
//   grazing angles (from 72 deg, certain beyond 84 deg); random dropout;
//   outside the range [depth_min, depth_max].
// - Quantisation to 1 / depth_factor m (TUM PNGs: 1/5000 m).
// Every random draw is a hash of (seed, frame, pixel), so the result does not
// depend on the thread count.
#pragma once

#include <cstdint>

#include "common/camera.h"
#include "common/image.h"

namespace dypho::synth {

struct KinectNoiseParams {
  double depth_min = 0.3;        // nearer reads 0 [m]
  double depth_max = 8.0;        // farther reads 0 [m]
  double dropout = 0.005;        // probability of a random hole per pixel
  double depth_factor = 5000.0;  // quantisation: units per metre
};

// Axial standard deviation [m] at depth z [m] and incidence angle theta [rad].
double KinectAxialSigma(double z, double theta);
// Lateral standard deviation [px at fx = 525] at incidence angle theta [rad].
double KinectLateralSigmaPx(double theta);

// Sensor depth from exact depth [m] (0 = nothing) and |cos| of the incidence
// angle per pixel (as RenderQuads gives them). 0 marks holes.
ImageF ApplyKinectNoise(const ImageF& depth, const ImageF& cos_incidence, const Camera& camera,
                        const KinectNoiseParams& params, uint64_t seed, int frame);

}  // namespace dypho::synth
