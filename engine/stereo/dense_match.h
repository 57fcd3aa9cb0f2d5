// ELAS stage 4: per-pixel MAP disparity given the plane prior and the grid of
// support disparities.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "engine/stereo/disparity.h"
#include "engine/stereo/support_points.h"

namespace dypho::stereo {

struct DenseMatch {
  cv::Mat disparity;   // CV_32F [px]; -1 where no estimate
  cv::Mat confidence;  // CV_32F in [0, 1): 1 - exp(-(E_second - E_best))
};

// For each pixel with a prior mu (not NaN) and texture >= match_texture,
// minimises over the candidate set
//   D = {round(mu) - plane_radius .. round(mu) + plane_radius} U grid(u, v)
// the energy
//   E(d) = beta |f_ref(u, v) - f_other(u -+ d, v)|_1 - log(gamma + exp(-(d - round(mu))^2 / (2 sigma^2)))
// where grid(u, v) holds d-1, d, d+1 of every support point in the pixel's
// grid_size cell and its 8 neighbours. right_image: the right image is the
// reference (matches at u + d in the left); its support points are at (u - d, v).
// E is evaluated in 16-bit fixed point, E / beta in units of 1/S of an L1 step
// (S = 16 with the defaults; the prior term rounded to 1/S, a change of at most
// beta / (2 S) = 0.000625 in E): the first candidate with the lowest energy wins.
// E_second is the lowest energy at |d - d_best| > 1. With subpixel (and left
// reference), a parabola through the L1 costs at d-1, d, d+1 refines d.
// With AVX2 (DYPHO_NATIVE_ARCH on a CPU that has it) eight candidates are
// evaluated at once; the result is identical to MatchDenseReference's.
DenseMatch MatchDense(const cv::Mat& desc_ref, const cv::Mat& desc_other, const cv::Mat& texture_ref,
                      const cv::Mat& prior, const std::vector<SupportPoint>& points,
                      bool right_image, const ElasOptions& options);

// The same, one candidate at a time (the reference the tests compare with).
DenseMatch MatchDenseReference(const cv::Mat& desc_ref, const cv::Mat& desc_other, const cv::Mat& texture_ref,
                               const cv::Mat& prior, const std::vector<SupportPoint>& points,
                               bool right_image, const ElasOptions& options);

// True when MatchDense was compiled with its AVX2 path.
bool MatchDenseIsVectorised();

}  // namespace dypho::stereo
