#include "tracker/orb_descriptor.h"

#include <array>
#include <cmath>
#include <random>
#include <set>
#include <utility>

#include <opencv2/core.hpp>

namespace dypho::orb {
namespace {

constexpr double kPatternSigma = 31.0 / 5.0;  // [px] BRIEF G II sampling for a 31 px patch
constexpr double kPatternRadius = 13.5;       // [px] pattern points lie in this disc
constexpr int kDescriptorPairs = 8 * kDescriptorBytes;

}  // namespace

std::vector<PatternPair> MakePattern() {
  std::mt19937 rng(0x0b5e55edu);
  auto uniform = [&rng]() { return (static_cast<double>(rng()) + 0.5) / 4294967296.0; };
  auto point = [&]() {
    for (;;) {
      const double r = std::sqrt(-2.0 * std::log(uniform()));
      const double a = 2.0 * M_PI * uniform();
      const double x = std::round(kPatternSigma * r * std::cos(a));
      const double y = std::round(kPatternSigma * r * std::sin(a));
      if (x * x + y * y <= kPatternRadius * kPatternRadius) return std::make_pair(x, y);
    }
  };
  std::vector<PatternPair> pattern;
  std::set<std::array<int, 4>> seen;
  while (static_cast<int>(pattern.size()) < kDescriptorPairs) {
    const auto p1 = point();
    const auto p2 = point();
    if (p1 == p2) continue;
    const std::array<int, 4> key{static_cast<int>(p1.first), static_cast<int>(p1.second),
                                 static_cast<int>(p2.first), static_cast<int>(p2.second)};
    if (!seen.insert(key).second) continue;
    pattern.push_back({static_cast<float>(p1.first), static_cast<float>(p1.second),
                       static_cast<float>(p2.first), static_cast<float>(p2.second)});
  }
  return pattern;
}

float CentroidAngle(const cv::Mat& image, int x, int y, const std::vector<int>& u_max) {
  const uint8_t* center = image.ptr<uint8_t>(y) + x;
  const int step = static_cast<int>(image.step1());
  int m01 = 0, m10 = 0;
  for (int u = -kHalfPatch; u <= kHalfPatch; ++u) m10 += u * center[u];
  for (int v = 1; v <= kHalfPatch; ++v) {
    int v_sum = 0;
    const int d = u_max[v];
    for (int u = -d; u <= d; ++u) {
      const int below = center[u + v * step];
      const int above = center[u - v * step];
      v_sum += below - above;
      m10 += u * (below + above);
    }
    m01 += v * v_sum;
  }
  float angle = cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
  if (angle >= 360.f) angle -= 360.f;
  return angle;
}

void ComputeDescriptor(const cv::Mat& blurred, int x, int y, float angle_deg,
                       const std::vector<PatternPair>& pattern, uint8_t* out) {
  const float a = angle_deg * static_cast<float>(M_PI / 180.0);
  const float c = std::cos(a), s = std::sin(a);
  const uint8_t* center = blurred.ptr<uint8_t>(y) + x;
  const int step = static_cast<int>(blurred.step1());
  auto sample = [&](float px, float py) {
    const int u = cvRound(px * c - py * s);
    const int v = cvRound(px * s + py * c);
    return center[v * step + u];
  };
  for (int byte = 0; byte < kDescriptorBytes; ++byte) {
    uint8_t value = 0;
    for (int bit = 0; bit < 8; ++bit) {
      const PatternPair& p = pattern[8 * byte + bit];
      value |= static_cast<uint8_t>((sample(p.x1, p.y1) < sample(p.x2, p.y2)) << bit);
    }
    out[byte] = value;
  }
}

}  // namespace dypho::orb
