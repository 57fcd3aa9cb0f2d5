#include "tracker/backend/loop_verification.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include <Eigen/Geometry>

#include "common/check.h"

namespace dypho {
namespace {

// Umeyama (rigid) of b onto a over the selected indices.
Rigid3d Fit(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b, const std::vector<int>& idx) {
  Eigen::Matrix3Xd src(3, idx.size()), dst(3, idx.size());
  for (size_t j = 0; j < idx.size(); ++j) {
    src.col(j) = b[idx[j]];
    dst.col(j) = a[idx[j]];
  }
  const Eigen::Matrix4d m = Eigen::umeyama(src, dst, /*with_scaling=*/false);
  return Rigid3d(Eigen::Quaterniond(Eigen::Matrix3d(m.block<3, 3>(0, 0))), m.block<3, 1>(0, 3));
}

int Classify(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b, const Rigid3d& t,
             double threshold, std::vector<char>* inliers, double* rmse) {
  inliers->assign(a.size(), 0);
  int n = 0;
  double sum = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = (a[i] - t * b[i]).norm();
    if (d <= threshold) {
      (*inliers)[i] = 1;
      ++n;
      sum += d * d;
    }
  }
  *rmse = n > 0 ? std::sqrt(sum / n) : 0.0;
  return n;
}

}  // namespace

bool LoopVerificationOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  if (ransac_iterations < 1) {
    e << "ransac_iterations must be >= 1 (got " << ransac_iterations << ")";
  } else if (!(inlier_distance > 0.0) || !std::isfinite(inlier_distance)) {
    e << "inlier_distance must be > 0 m (got " << inlier_distance << ")";
  } else if (min_inliers < 3) {
    e << "min_inliers must be >= 3 (got " << min_inliers << ")";
  } else if (refinement_rounds < 0) {
    e << "refinement_rounds must be >= 0 (got " << refinement_rounds << ")";
  } else {
    return true;
  }
  if (error != nullptr) *error = "LoopVerificationOptions." + e.str();
  return false;
}

LoopVerification VerifyLoop3d(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                              const LoopVerificationOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  DYPHO_CHECK_INPUT(a.size() == b.size()) << "VerifyLoop3d: " << a.size() << " points_a but " << b.size() << " points_b";
  for (size_t i = 0; i < a.size(); ++i)
    DYPHO_CHECK_INPUT(a[i].allFinite() && b[i].allFinite()) << "VerifyLoop3d: correspondence " << i << " is not finite";
  LoopVerification out;
  out.inliers.assign(a.size(), 0);
  if (static_cast<int>(a.size()) < std::max(3, options.min_inliers)) {
    out.reason = "too few correspondences (" + std::to_string(a.size()) + " < " +
                 std::to_string(std::max(3, options.min_inliers)) + ")";
    return out;
  }
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(a.size()) - 1);
  int best = -1;
  std::vector<char> inliers;
  double rmse = 0.0;
  for (int it = 0; it < options.ransac_iterations; ++it) {
    std::vector<int> sample;
    while (sample.size() < 3) {
      const int i = pick(rng);
      if (std::find(sample.begin(), sample.end(), i) == sample.end()) sample.push_back(i);
    }
    // A degenerate (near-collinear) sample gives no rotation.
    const Eigen::Vector3d u = b[sample[1]] - b[sample[0]], v = b[sample[2]] - b[sample[0]];
    if (u.cross(v).norm() < 1e-6 * std::max(1e-12, u.norm() * v.norm())) continue;
    const Rigid3d t = Fit(a, b, sample);
    const int n = Classify(a, b, t, options.inlier_distance, &inliers, &rmse);
    if (n > best) {
      best = n;
      out.a_from_b = t;
      out.inliers = inliers;
      out.rmse = rmse;
    }
  }
  // Refinement: Umeyama on all inliers until the set is stable.
  for (int round = 0; round < options.refinement_rounds && best >= 3; ++round) {
    std::vector<int> idx;
    for (size_t i = 0; i < out.inliers.size(); ++i)
      if (out.inliers[i]) idx.push_back(static_cast<int>(i));
    const Rigid3d t = Fit(a, b, idx);
    const int n = Classify(a, b, t, options.inlier_distance, &inliers, &rmse);
    if (n < best) break;
    const bool same = inliers == out.inliers;
    best = n;
    out.a_from_b = t;
    out.inliers = inliers;
    out.rmse = rmse;
    if (same) break;
  }
  out.num_inliers = std::max(0, best);
  out.accepted = out.num_inliers >= options.min_inliers;
  if (!out.accepted)
    out.reason = "too few inliers (" + std::to_string(out.num_inliers) + " < " + std::to_string(options.min_inliers) + ")";
  return out;
}

}  // namespace dypho
