// Geometric verification of a loop candidate for RGB-D (and stereo): the
// map points of the candidate keyframe matched to those of the current one
// give 3D-3D correspondences; RANSAC on minimal sets of 3 with the closed
// form of Umeyama (rigid, no scale: depth fixes the scale; Eigen::umeyama),
// then a refinement (Umeyama on all inliers, re-classified, until the set no
// longer changes). The loop is accepted with at least min_inliers inliers.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/rigid3.h"

namespace dypho {

struct LoopVerificationOptions {
  int ransac_iterations = 300;   // minimal samples tried, >= 1
  double inlier_distance = 0.05; // [m] |a - a_from_b * b| for an inlier, > 0
  int min_inliers = 30;          // accepted with at least this many inliers, >= 3
  int refinement_rounds = 5;     // Umeyama on all inliers at most this often, >= 0
  unsigned seed = 1;             // RANSAC sampling (deterministic)

  bool IsValid(std::string* error) const;
};

struct LoopVerification {
  bool accepted = false;
  Rigid3d a_from_b;             // maps points_b onto points_a (when some model was found)
  int num_inliers = 0;
  std::vector<char> inliers;    // per correspondence
  double rmse = 0.0;            // [m] over the inliers
  std::string reason;           // why it was rejected; empty when accepted
};

// points_a[i] and points_b[i] are the same map point seen from the two
// places. Throws InvalidInput for invalid options, different sizes or
// non-finite points.
LoopVerification VerifyLoop3d(const std::vector<Eigen::Vector3d>& points_a, const std::vector<Eigen::Vector3d>& points_b,
                              const LoopVerificationOptions& options);

}  // namespace dypho
