#include "engine/synth/depth_noise.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "engine/synth/random.h"

namespace dypho::synth {
namespace {

constexpr double kMaxTheta = 89.0 * M_PI / 180.0;
// Smaller images are processed on one thread: thread hand-offs would cost more.
constexpr long kMinParallelPixels = 1 << 16;

// Two neighbouring depths are on different surfaces when they differ by more
// than this [m] at depth z [m].
double JumpThreshold(double z) { return 0.03 + 0.03 * z; }

// Random streams per pixel.
enum Stream : uint64_t {
  kLateralU = 1,
  kLateralU2,
  kLateralV,
  kLateralV2,
  kEdge,
  kGrazing,
  kDropout,
  kAxialA,
  kAxialB,
};

}  // namespace

double KinectAxialSigma(double z, double theta) {
  double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
  theta = std::min(std::abs(theta), kMaxTheta);
  if (theta > M_PI / 3.0) {
    const double r = theta / (M_PI / 2.0 - theta);
    sigma += 0.0001 / std::sqrt(std::max(z, 1e-3)) * r * r;
  }
  return sigma;
}

double KinectLateralSigmaPx(double theta) {
  theta = std::min(std::abs(theta), kMaxTheta);
  return 0.8 + 0.035 * theta / (M_PI / 2.0 - theta);
}

ImageF ApplyKinectNoise(const ImageF& depth, const ImageF& cos_incidence, const Camera& camera,
                        const KinectNoiseParams& params, uint64_t seed, int frame) {
  const int W = depth.width(), H = depth.height();
  DYPHO_CHECK_INPUT(depth.channels() == 1 && cos_incidence.channels() == 1 && cos_incidence.width() == W &&
                    cos_incidence.height() == H)
      << "ApplyKinectNoise: depth " << W << "x" << H << " and cos_incidence " << cos_incidence.width() << "x"
      << cos_incidence.height() << " must be single-channel, same size";
  DYPHO_CHECK_INPUT(params.depth_factor > 0.0) << "ApplyKinectNoise: depth_factor must be > 0";
  // Pixel distances scale with the focal length (the model is for 525 px).
  const double px_scale = camera.fx / 525.0;
  const int radius = std::max(1, static_cast<int>(std::lround(2.0 * px_scale)));
  const uint64_t frame_key = Hash(seed, 0xde9e7, static_cast<uint64_t>(frame));
  const bool parallel = static_cast<long>(W) * H >= kMinParallelPixels;

  // Local min and max of the depth in a (2 radius + 1)^2 window (separable),
  // so that the exact edge search runs only where an edge can be.
  ImageF local_min(W, H, 1), local_max(W, H, 1);
  {
    ImageF row_min(W, H, 1), row_max(W, H, 1);
#pragma omp parallel for schedule(static) if (parallel)
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) {
        float lo = depth.at(x, y), hi = lo;
        for (int xx = std::max(0, x - radius); xx <= std::min(W - 1, x + radius); ++xx) {
          lo = std::min(lo, depth.at(xx, y));
          hi = std::max(hi, depth.at(xx, y));
        }
        row_min.at(x, y) = lo;
        row_max.at(x, y) = hi;
      }
    }
#pragma omp parallel for schedule(static) if (parallel)
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) {
        float lo = row_min.at(x, y), hi = row_max.at(x, y);
        for (int yy = std::max(0, y - radius); yy <= std::min(H - 1, y + radius); ++yy) {
          lo = std::min(lo, row_min.at(x, yy));
          hi = std::max(hi, row_max.at(x, yy));
        }
        local_min.at(x, y) = lo;
        local_max.at(x, y) = hi;
      }
    }
  }

  constexpr double kCosGrazingStart = 0.30901699437494745;  // cos(72 deg)
  constexpr double kCosGrazingEnd = 0.10452846326765346;    // cos(84 deg)
  constexpr double kGrazingStart = 72.0 * M_PI / 180.0, kGrazingEnd = 84.0 * M_PI / 180.0;
  ImageF out(W, H, 1, 0.0f);

#pragma omp parallel for schedule(dynamic, 8) if (parallel)
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const double z = depth.at(x, y);
      if (!(z > 0.0)) continue;
      const uint64_t key = Hash(frame_key, static_cast<uint64_t>(y) * W + x);
      auto draw = [&](Stream s) { return Mix64(key ^ (s * 0x9e3779b97f4a7c15ULL)); };
      // Distance (Chebyshev, px) to the nearest nearer surface (this pixel is
      // then on the far side of an edge) and to the nearest farther surface.
      int far_side = radius + 1, near_side = radius + 1;
      const double thr = JumpThreshold(z);
      const double lo = local_min.at(x, y), hi = local_max.at(x, y);
      if (!(lo > 0.0) || lo < z - thr || hi > z + JumpThreshold(hi)) {
        for (int dy = -radius; dy <= radius; ++dy) {
          const int yy = y + dy;
          if (yy < 0 || yy >= H) continue;
          for (int dx = -radius; dx <= radius; ++dx) {
            const int xx = x + dx;
            if (xx < 0 || xx >= W || (dx == 0 && dy == 0)) continue;
            const double zq = depth.at(xx, yy);
            const int d = std::max(std::abs(dx), std::abs(dy));
            if (!(zq > 0.0) || zq < z - thr) {
              far_side = std::min(far_side, d);
            } else if (zq > z + JumpThreshold(zq)) {
              near_side = std::min(near_side, d);
            }
          }
        }
      }
      const bool near_edge = far_side <= radius || near_side <= radius;
      int sx = x, sy = y;
      if (near_edge) {
        // Holes next to edges.
        double p_edge = 0.0;
        if (far_side <= radius) p_edge = 2 * far_side <= radius + 1 ? 0.75 : 0.3;
        if (near_side == 1) p_edge = std::max(p_edge, 0.15);
        if (p_edge > 0.0 && UnitFromBits(draw(kEdge)) < p_edge) continue;
        // Lateral noise near edges: read a randomly shifted pixel.
        const double cos_here = std::min(1.0, std::max(0.0, static_cast<double>(cos_incidence.at(x, y))));
        const double sigma_l = KinectLateralSigmaPx(std::acos(cos_here)) * px_scale;
        sx = std::min(W - 1,
                      std::max(0, static_cast<int>(std::lround(
                                      x + sigma_l * NormalFromBits(draw(kLateralU), draw(kLateralU2))))));
        sy = std::min(H - 1,
                      std::max(0, static_cast<int>(std::lround(
                                      y + sigma_l * NormalFromBits(draw(kLateralV), draw(kLateralV2))))));
      }
      const double zs = depth.at(sx, sy);
      if (!(zs > 0.0)) continue;
      const double cos_theta = std::min(1.0, std::max(0.0, static_cast<double>(cos_incidence.at(sx, sy))));
      // Grazing angles.
      if (cos_theta <= kCosGrazingEnd) continue;
      // theta matters for the noise only beyond 60 deg (cos < 0.5).
      const double theta = cos_theta < 0.5 ? std::acos(cos_theta) : 0.0;
      if (cos_theta < kCosGrazingStart) {
        const double f = (theta - kGrazingStart) / (kGrazingEnd - kGrazingStart);
        if (UnitFromBits(draw(kGrazing)) < f * f) continue;
      }
      // Random dropout and range limits.
      if (UnitFromBits(draw(kDropout)) < params.dropout) continue;
      if (zs < params.depth_min || zs > params.depth_max) continue;
      // Axial noise, then quantisation.
      const double noisy = zs + KinectAxialSigma(zs, theta) * NormalFromBits(draw(kAxialA), draw(kAxialB));
      const double quantised = std::round(noisy * params.depth_factor) / params.depth_factor;
      if (quantised < params.depth_min || quantised > params.depth_max) continue;
      out.at(x, y) = static_cast<float>(quantised);
    }
  }
  return out;
}

}  // namespace dypho::synth
