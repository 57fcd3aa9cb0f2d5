// Procedural water and sky of the synthetic harbour, changing per frame.
//
// Sky: a gradient from a pale horizon to a deeper zenith blue, with clouds
// (fractal value noise on a plane kCloudHeight above the water) drifting
// with the wind.
// Water: the plane z = 0 with a sum of travelling waves (deep-water
// dispersion, omega = sqrt(g k)); per pixel the wave slopes tilt the normal,
// the viewing ray is reflected into the sky (Schlick's Fresnel term mixes the
// reflection with the water's own colour) and sun glints are added. Waves
// shorter than the pixel footprint are faded out, so distant water does not
// alias into noise.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

namespace dypho::synth {

class WaterSky {
 public:
  explicit WaterSky(uint64_t seed);
  // Sky colour (RGB in [0, 1]) along world direction `dir` (unit) at time t [s].
  Eigen::Vector3f Sky(const Eigen::Vector3d& dir, double t) const;
  // Colour of the water at world point `p` (p.z = 0) seen along the unit
  // ray `dir` (dir.z < 0) with a pixel footprint of `footprint` metres on
  // the surface, at time t [s].
  Eigen::Vector3f Water(const Eigen::Vector3d& p, const Eigen::Vector3d& dir, double footprint, double t) const;

 private:
  struct Wave {
    Eigen::Vector2d direction;  // unit, horizontal
    double k;                   // wave number [rad/m]
    double omega;               // angular frequency [rad/s]
    double slope;               // amplitude * k (steepness)
    double phase;               // [rad]
  };
  double Clouds(const Eigen::Vector2d& q) const;  // cover in [0, 1] at plane coordinates [m]
  double ValueNoise(double x, double y, uint64_t octave) const;
  uint64_t seed_;
  std::array<Wave, 7> waves_;
};

}  // namespace dypho::synth
