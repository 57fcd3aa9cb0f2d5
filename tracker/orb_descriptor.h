// The ORB descriptor's pieces (tracker/orb_extractor.cc): the fixed
// sampling pattern of the 256 point pairs, the intensity-centroid
// orientation and the rotated binary test. Internal to the tracker.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace dypho::orb {

constexpr int kHalfPatch = 15;  // [px] radius of the orientation disc
constexpr int kDescriptorBytes = 32;

struct PatternPair {
  float x1, y1, x2, y2;
};

// The 256 point pairs of the descriptor: drawn from an isotropic Gaussian
// with a fixed seed (std::mt19937's sequence is fixed by the standard; the
// Gaussian is our own Box-Muller so the pattern is the same everywhere).
std::vector<PatternPair> MakePattern();

// Intensity centroid orientation [deg] in [0, 360) over a disc of radius
// kHalfPatch around (x, y) (integer pixel, at least kHalfPatch from the
// border); u_max[v]: the disc's half-width at row v.
float CentroidAngle(const cv::Mat& image, int x, int y, const std::vector<int>& u_max);

// The 32 descriptor bytes at (x, y) of the blurred level, the pattern
// rotated by angle_deg.
void ComputeDescriptor(const cv::Mat& blurred, int x, int y, float angle_deg, const std::vector<PatternPair>& pattern,
                       uint8_t* out);

}  // namespace dypho::orb
