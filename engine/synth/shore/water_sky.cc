#include "engine/synth/shore/water_sky.h"

#include <algorithm>
#include <cmath>

#include "engine/synth/random.h"

namespace dypho::synth {
namespace {

constexpr double kCloudHeight = 400.0;  // [m]
constexpr double kCloudScale = 220.0;   // size of the largest cloud features [m]
const Eigen::Vector2d kWind(7.0, 2.5);  // cloud drift [m/s] on the cloud plane
constexpr double kGravity = 9.81;       // [m/s^2]

double Smooth(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
double SmoothStep(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}
Eigen::Vector3f Mix(const Eigen::Vector3f& a, const Eigen::Vector3f& b, double t) {
  return a + static_cast<float>(t) * (b - a);
}

}  // namespace

WaterSky::WaterSky(uint64_t seed) : seed_(Hash(seed, 0x3a7e5)) {
  Rng rng(seed_);
  // Wavelengths from 3 m down to 0.25 m, travelling roughly towards the shore.
  const double wavelengths[] = {3.1, 1.9, 1.2, 0.8, 0.55, 0.37, 0.25};
  for (size_t i = 0; i < waves_.size(); ++i) {
    Wave& w = waves_[i];
    const double angle = M_PI / 2 + rng.Uniform(-0.9, 0.9);
    w.direction = Eigen::Vector2d(std::cos(angle), std::sin(angle));
    w.k = 2 * M_PI / wavelengths[i];
    w.omega = std::sqrt(kGravity * w.k);
    w.slope = rng.Uniform(0.07, 0.13);
    w.phase = rng.Uniform(0, 2 * M_PI);
  }
}

double WaterSky::ValueNoise(double x, double y, uint64_t octave) const {
  const double fx = std::floor(x), fy = std::floor(y);
  const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  auto v = [&](int64_t a, int64_t b) {
    return UnitFromBits(Hash(seed_ ^ octave, static_cast<uint64_t>(a), static_cast<uint64_t>(b)));
  };
  const double tx = Smooth(x - fx), ty = Smooth(y - fy);
  const double top = v(ix, iy) + tx * (v(ix + 1, iy) - v(ix, iy));
  const double bottom = v(ix, iy + 1) + tx * (v(ix + 1, iy + 1) - v(ix, iy + 1));
  return top + ty * (bottom - top);
}

double WaterSky::Clouds(const Eigen::Vector2d& q) const {
  double sum = 0.0, amplitude = 0.5, frequency = 1.0 / kCloudScale;
  for (uint64_t o = 0; o < 5; ++o) {
    sum += amplitude * ValueNoise(q.x() * frequency, q.y() * frequency, o);
    amplitude *= 0.5;
    frequency *= 2.03;
  }
  return SmoothStep(0.42, 0.68, sum / 0.97);
}

Eigen::Vector3f WaterSky::Sky(const Eigen::Vector3d& dir, double t) const {
  const Eigen::Vector3f horizon(0.66f, 0.79f, 0.95f), zenith(0.22f, 0.42f, 0.82f), cloud(0.84f, 0.88f, 0.97f),
      cloud_shadow(0.60f, 0.66f, 0.80f);
  const double elevation = std::asin(std::clamp(dir.z(), 0.0, 1.0));
  Eigen::Vector3f c = Mix(horizon, zenith, std::pow(elevation / (M_PI / 2), 0.6));
  const double dz = std::max(dir.z(), 0.02);
  const Eigen::Vector2d q = Eigen::Vector2d(dir.x(), dir.y()) * (kCloudHeight / dz) + kWind * t;
  const double cover = Clouds(q);
  if (cover > 0.0) {
    // Darker cloud bases where the cloud is thick; clouds fade into the haze at the horizon.
    const double thick = Clouds(q * 1.9 + Eigen::Vector2d(311.0, -97.0));
    const Eigen::Vector3f cc = Mix(cloud, cloud_shadow, 0.6 * thick);
    c = Mix(c, cc, cover * SmoothStep(0.0, 0.12, dir.z()));
  }
  return c;
}

Eigen::Vector3f WaterSky::Water(const Eigen::Vector3d& p, const Eigen::Vector3d& dir, double footprint,
                                double t) const {
  // Wave slopes (gradient of the height field), faded where a wave is
  // shorter than about two pixel footprints.
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();
  double glint_sharpness = 0.0;
  for (const Wave& w : waves_) {
    const double fade = std::exp(-0.5 * std::pow(w.k * footprint / M_PI, 2));
    if (fade < 1e-3) continue;
    const double arg = w.k * (w.direction.x() * p.x() + w.direction.y() * p.y()) - w.omega * t + w.phase;
    gradient += fade * w.slope * std::cos(arg) * w.direction;
    glint_sharpness += fade;
  }
  const Eigen::Vector3d normal = Eigen::Vector3d(-gradient.x(), -gradient.y(), 1.0).normalized();
  Eigen::Vector3d r = dir - 2.0 * dir.dot(normal) * normal;
  if (r.z() < 0.01) r.z() = 0.01;
  r.normalize();
  const double cos_theta = std::clamp(-dir.dot(normal), 0.0, 1.0);
  const double fresnel = 0.02 + 0.98 * std::pow(1.0 - cos_theta, 5.0);
  const Eigen::Vector3f body(0.05f, 0.20f, 0.30f);
  Eigen::Vector3f c = Mix(body, Sky(r, t), std::clamp(fresnel * 1.6, 0.0, 1.0));
  // Sun glints (the sun high behind the camera's left shoulder is not
  // visible; glints come from wave facets that mirror it).
  static const Eigen::Vector3d kSun = Eigen::Vector3d(-0.35, 0.75, 0.56).normalized();
  const double g = std::max(0.0, r.dot(kSun));
  const double glint = std::pow(g, 300.0) * 2.5 * std::min(1.0, glint_sharpness / 3.0);
  c += Eigen::Vector3f(0.85f, 0.9f, 1.0f) * static_cast<float>(glint);
  return c.cwiseMin(1.0f).cwiseMax(0.0f);
}

}  // namespace dypho::synth
