#include "engine/eval/ate.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <string>

#include "common/check.h"
#include "engine/eval/associate.h"

namespace dypho {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t n = values.size();
  std::nth_element(values.begin(), values.begin() + n / 2, values.end());
  const double upper = values[n / 2];
  if (n % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + n / 2);
  return 0.5 * (lower + upper);
}

void CheckTrajectory(const Trajectory& trajectory, const char* what) {
  DYPHO_CHECK_INPUT(trajectory.timestamps.size() == trajectory.world_from_cam.size())
      << what << " trajectory has " << trajectory.timestamps.size() << " timestamps but "
      << trajectory.world_from_cam.size() << " poses";
  for (size_t i = 0; i < trajectory.size(); ++i) {
    const Rigid3d& pose = trajectory.world_from_cam[i];
    DYPHO_CHECK_INPUT(pose.translation.allFinite() && pose.rotation.coeffs().allFinite())
        << what << " trajectory: pose " << i << " (t = " << trajectory.timestamps[i] << ") is not finite";
    DYPHO_CHECK_INPUT(std::isfinite(trajectory.timestamps[i]))
        << what << " trajectory: timestamp " << i << " is not finite";
    DYPHO_CHECK_INPUT(i == 0 || trajectory.timestamps[i] > trajectory.timestamps[i - 1])
        << what << " trajectory: timestamp " << i << " (" << trajectory.timestamps[i]
        << ") does not increase";
  }
}

// The world_from_cam pose as a 4x4 matrix with the translation scaled.
Eigen::Matrix4d ScaleTranslation(Eigen::Matrix4d m, double scale) {
  m.topRightCorner<3, 1>() *= scale;
  return m;
}

// Rotation angle of the upper-left 3x3 block [rad]: arccos((trace - 1) / 2)
// as in the TUM tool, evaluated with atan2 for accuracy near 0 and pi.
double RotationAngleOf(const Eigen::Matrix4d& m) {
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double cos_angle = 0.5 * (r.trace() - 1.0);
  const Eigen::Vector3d axis(r(2, 1) - r(1, 2), r(0, 2) - r(2, 0), r(1, 0) - r(0, 1));
  const double sin_angle = 0.5 * axis.norm();
  return std::atan2(sin_angle, std::min(1.0, std::max(-1.0, cos_angle)));
}

}  // namespace

ErrorStats ComputeErrorStats(const std::vector<double>& errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) return s;
  double sum = 0.0, sum_sq = 0.0;
  s.min = errors[0];
  s.max = errors[0];
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
    s.min = std::min(s.min, e);
    s.max = std::max(s.max, e);
  }
  const double n = static_cast<double>(errors.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  s.median = Median(errors);
  return s;
}

bool AteOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(std::isfinite(max_time_difference) && max_time_difference > 0)) {
    msg << "max_time_difference must be finite and > 0 (got " << max_time_difference << ")";
  } else if (!std::isfinite(time_offset)) {
    msg << "time_offset must be finite (got " << time_offset << ")";
  }
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

bool RpeOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(std::isfinite(delta) && delta > 0)) {
    msg << "delta must be finite and > 0 (got " << delta << ")";
  } else if (!std::isfinite(time_offset)) {
    msg << "time_offset must be finite (got " << time_offset << ")";
  } else if (!(std::isfinite(scale) && scale > 0)) {
    msg << "scale must be finite and > 0 (got " << scale << ")";
  }
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

Eigen::Vector3d AteResult::Align(const Eigen::Vector3d& p_est) const {
  return scale * (gt_from_est.rotation * p_est) + gt_from_est.translation;
}

Rigid3d AteResult::Align(const Rigid3d& world_from_cam_est) const {
  return Rigid3d(gt_from_est.rotation * world_from_cam_est.rotation, Align(world_from_cam_est.translation));
}

AteResult ComputeAte(const Trajectory& ground_truth, const Trajectory& estimate, const AteOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "AteOptions: " << error;
  CheckTrajectory(ground_truth, "ground-truth");
  CheckTrajectory(estimate, "estimated");

  const std::vector<TimestampMatch> matches = AssociateTimestamps(
      ground_truth.timestamps, estimate.timestamps, options.max_time_difference, options.time_offset);
  DYPHO_CHECK_INPUT(matches.size() >= 2)
      << "ATE: only " << matches.size() << " of " << estimate.size()
      << " estimated poses match a ground-truth pose within " << options.max_time_difference
      << " s (ground truth has " << ground_truth.size() << " poses); are the files from the same sequence?";

  const Eigen::Index n = static_cast<Eigen::Index>(matches.size());
  Eigen::Matrix3Xd est(3, n), gt(3, n);
  AteResult result;
  for (Eigen::Index k = 0; k < n; ++k) {
    const TimestampMatch& m = matches[k];
    gt.col(k) = ground_truth.world_from_cam[m.first].translation;
    est.col(k) = estimate.world_from_cam[m.second].translation;
    result.gt_indices.push_back(m.first);
    result.est_indices.push_back(m.second);
    result.timestamps.push_back(estimate.timestamps[m.second]);
  }

  if (options.estimate_scale) {
    const double spread = (est.colwise() - est.rowwise().mean()).squaredNorm();
    DYPHO_CHECK_INPUT(spread > 0) << "ATE with scale: the " << n
                                  << " matched estimated positions coincide; the scale is undefined";
  }
  // Closed-form alignment (Umeyama 1991; without scale it equals the
  // SVD-based solution of evaluate_ate.py's align()).
  const Eigen::Matrix4d gt_from_est = Eigen::umeyama(est, gt, options.estimate_scale);
  const Eigen::Matrix3d scaled_rotation = gt_from_est.topLeftCorner<3, 3>();
  result.scale = options.estimate_scale ? std::cbrt(scaled_rotation.determinant()) : 1.0;
  const Eigen::Matrix3d rotation = scaled_rotation / result.scale;
  result.gt_from_est = Rigid3d(Eigen::Quaterniond(rotation), gt_from_est.topRightCorner<3, 1>());

  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Vector3d aligned = scaled_rotation * est.col(k) + gt_from_est.topRightCorner<3, 1>();
    result.aligned_positions.push_back(aligned);
    result.gt_positions.push_back(gt.col(k));
    result.errors.push_back((aligned - gt.col(k)).norm());
  }
  result.translation = ComputeErrorStats(result.errors);
  result.unmatched_estimates = estimate.size() - matches.size();
  return result;
}

Trajectory AlignTrajectory(const Trajectory& estimate, const AteResult& ate) {
  Trajectory out;
  for (size_t i = 0; i < estimate.size(); ++i) {
    out.Add(estimate.timestamps[i], ate.Align(estimate.world_from_cam[i]));
  }
  return out;
}

RpeResult ComputeRpe(const Trajectory& ground_truth, const Trajectory& estimate, const RpeOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "RpeOptions: " << error;
  CheckTrajectory(ground_truth, "ground-truth");
  CheckTrajectory(estimate, "estimated");
  DYPHO_CHECK_INPUT(ground_truth.size() >= 2 && estimate.size() >= 2)
      << "RPE needs at least 2 poses in each trajectory (ground truth " << ground_truth.size()
      << ", estimate " << estimate.size() << ")";

  const std::vector<double>& stamps_gt = ground_truth.timestamps;
  const std::vector<double>& stamps_est = estimate.timestamps;
  const double offset = options.time_offset;

  // Overlap check of evaluate_rpe.py: estimated stamps reached by the round
  // trip estimate -> closest ground truth -> closest estimate.
  {
    std::vector<size_t> returned;
    for (double t_est : stamps_est) {
      const double t_gt = stamps_gt[FindClosestIndex(stamps_gt, t_est + offset)];
      returned.push_back(FindClosestIndex(stamps_est, t_gt - offset));
    }
    std::sort(returned.begin(), returned.end());
    const size_t distinct = std::unique(returned.begin(), returned.end()) - returned.begin();
    DYPHO_CHECK_INPUT(distinct >= 2)
        << "RPE: the estimated and ground-truth timestamps hardly overlap (estimate " << stamps_est.front()
        << ".." << stamps_est.back() << " s, ground truth " << stamps_gt.front() << ".." << stamps_gt.back()
        << " s); are the files from the same sequence?";
  }

  // Pairs at a fixed time delta; j == last is skipped as in the TUM tool.
  std::vector<std::pair<size_t, size_t>> pairs;
  for (size_t i = 0; i < stamps_est.size(); ++i) {
    const size_t j = FindClosestIndex(stamps_est, stamps_est[i] + options.delta);
    if (j != stamps_est.size() - 1) pairs.emplace_back(i, j);
  }

  std::vector<double> intervals;
  for (size_t k = 1; k < stamps_gt.size(); ++k) intervals.push_back(stamps_gt[k] - stamps_gt[k - 1]);
  const double gt_max_time_difference = 2.0 * Median(intervals);

  RpeResult result;
  std::vector<double> trans_errors, rot_errors;
  for (const auto& [i, j] : pairs) {
    const double t_est_0 = stamps_est[i], t_est_1 = stamps_est[j];
    const size_t g0 = FindClosestIndex(stamps_gt, t_est_0 + offset);
    const size_t g1 = FindClosestIndex(stamps_gt, t_est_1 + offset);
    if (std::abs(stamps_gt[g0] - (t_est_0 + offset)) > gt_max_time_difference ||
        std::abs(stamps_gt[g1] - (t_est_1 + offset)) > gt_max_time_difference) {
      continue;
    }
    const Eigen::Matrix4d e0 = estimate.world_from_cam[i].ToMatrix4();
    const Eigen::Matrix4d e1 = estimate.world_from_cam[j].ToMatrix4();
    const Eigen::Matrix4d p0 = ground_truth.world_from_cam[g0].ToMatrix4();
    const Eigen::Matrix4d p1 = ground_truth.world_from_cam[g1].ToMatrix4();
    const Eigen::Matrix4d relative_est = ScaleTranslation(e1.inverse() * e0, options.scale);
    const Eigen::Matrix4d relative_gt = p1.inverse() * p0;
    const Eigen::Matrix4d error44 = relative_est.inverse() * relative_gt;

    RpePair pair;
    pair.est_time_0 = t_est_0;
    pair.est_time_1 = t_est_1;
    pair.gt_time_0 = stamps_gt[g0];
    pair.gt_time_1 = stamps_gt[g1];
    pair.translation_error = error44.topRightCorner<3, 1>().norm();
    pair.rotation_error = RotationAngleOf(error44) * kRadToDeg;
    trans_errors.push_back(pair.translation_error);
    rot_errors.push_back(pair.rotation_error);
    result.pairs.push_back(pair);
  }
  DYPHO_CHECK_INPUT(result.pairs.size() >= 2)
      << "RPE: only " << result.pairs.size() << " pose pairs " << options.delta
      << " s apart match the ground truth (estimate spans " << (stamps_est.back() - stamps_est.front())
      << " s); use a shorter --rpe-delta or check the files";
  result.translation = ComputeErrorStats(trans_errors);
  result.rotation = ComputeErrorStats(rot_errors);
  return result;
}

}  // namespace dypho
