#include "engine/render/demo_scene.h"

#include <cmath>
#include <random>

namespace dypho {
namespace {

// Quaternion (w, x, y, z) rotating the z axis onto `normal`.
void QuatFromNormal(const Eigen::Vector3d& normal, float q[4]) {
  const Eigen::Quaterniond r = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), normal.normalized());
  q[0] = float(r.w());
  q[1] = float(r.x());
  q[2] = float(r.y());
  q[3] = float(r.z());
}

void AddSplat(GaussianCloud* cloud, const Eigen::Vector3d& p, const Eigen::Vector3d& normal, double radius,
              double thickness, float logit, const Eigen::Vector3f& rgb, const float* extra_sh = nullptr) {
  const float mean[3] = {float(p.x()), float(p.y()), float(p.z())};
  const float ls[3] = {float(std::log(radius)), float(std::log(radius)), float(std::log(thickness))};
  float q[4];
  QuatFromNormal(normal, q);
  float coeffs[48] = {};
  for (int c = 0; c < 3; ++c) coeffs[c] = RgbToShDc(rgb[c]);
  if (extra_sh) {
    for (int k = 3; k < 3 * cloud->sh_coeffs; ++k) coeffs[k] = extra_sh[k];
  }
  cloud->Add(mean, ls, q, logit, coeffs);
}

}  // namespace

GaussianCloud MakeDemoScene() {
  GaussianCloud cloud;
  cloud.sh_coeffs = 16;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  // Floor: y = 0.6 (y down), checkered 0.25 m squares.
  for (double x = -2.0; x <= 2.0; x += 0.05) {
    for (double z = -1.0; z <= 3.0; z += 0.05) {
      const bool dark = (static_cast<int>(std::floor(x / 0.25)) + static_cast<int>(std::floor(z / 0.25))) & 1;
      const Eigen::Vector3f rgb = dark ? Eigen::Vector3f(0.15f, 0.18f, 0.22f) : Eigen::Vector3f(0.85f, 0.82f, 0.75f);
      AddSplat(&cloud, {x, 0.6, z}, Eigen::Vector3d::UnitY(), 0.03, 0.002, 4.0f, rgb);
    }
  }
  // Spheres: centre, radius, colour; the third has view-dependent colour.
  struct Ball {
    Eigen::Vector3d c;
    double r;
    Eigen::Vector3f rgb;
    bool shiny;
  };
  const Ball balls[] = {{{-0.9, 0.25, 1.0}, 0.35, {0.9f, 0.25f, 0.2f}, false},
                        {{0.2, 0.1, 1.4}, 0.5, {0.2f, 0.55f, 0.9f}, false},
                        {{1.1, 0.3, 0.7}, 0.3, {0.3f, 0.8f, 0.35f}, true}};
  for (const Ball& b : balls) {
    const int n = static_cast<int>(2500 * b.r * b.r / 0.1);
    for (int i = 0; i < n; ++i) {
      // Fibonacci sphere points.
      const double t = (i + 0.5) / n;
      const double phi = std::acos(1 - 2 * t), theta = M_PI * (1 + std::sqrt(5.0)) * i;
      const Eigen::Vector3d nrm(std::cos(theta) * std::sin(phi), std::cos(phi), std::sin(theta) * std::sin(phi));
      const float shade = 0.75f + 0.25f * float(-nrm.y());
      float sh[48] = {};
      if (b.shiny) {
        for (int k = 3; k < 48; ++k) sh[k] = 0.25f * float(u(rng));
      }
      AddSplat(&cloud, b.c + b.r * nrm, nrm, 1.6 * b.r * std::sqrt(4 * M_PI / n) / 2, 0.004, 3.0f, shade * b.rgb,
               b.shiny ? sh : nullptr);
    }
  }
  // A ring of translucent blobs.
  for (int i = 0; i < 24; ++i) {
    const double a = 2 * M_PI * i / 24;
    const Eigen::Vector3d p(1.6 * std::cos(a), -0.3 + 0.1 * std::sin(3 * a), 1.5 + 1.6 * std::sin(a));
    const Eigen::Vector3f rgb(0.5f + 0.5f * float(std::cos(a)), 0.5f + 0.5f * float(std::sin(a)), 0.8f);
    AddSplat(&cloud, p, Eigen::Vector3d(u(rng), u(rng), u(rng)), 0.12, 0.05, -0.5f, rgb);
  }
  return cloud;
}

Rigid3d DemoCamFromWorld(double orbit_angle) {
  // Camera centre on a circle around the scene centre (0, 0.2, 1.2), looking at it.
  const Eigen::Vector3d target(0.0, 0.2, 1.2);
  const Eigen::Vector3d center = target + Eigen::Vector3d(3.2 * std::sin(orbit_angle), -1.4, -3.2 * std::cos(orbit_angle));
  const Eigen::Vector3d z = (target - center).normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();  // y is down: x = y cross z
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_cam_rot;
  world_from_cam_rot << x, y, z;
  const Rigid3d world_from_cam(Eigen::Quaterniond(world_from_cam_rot), center);
  return world_from_cam.Inverse();
}

Camera DemoCamera(int width, int height) { return Camera::FromFov(width, height, 60.0 * M_PI / 180.0); }

}  // namespace dypho
