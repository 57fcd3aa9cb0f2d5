#include "masking/epipolar_check.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/video/tracking.hpp>
#include <sstream>
#include <string>
#include <utility>

#include "common/check.h"
#include "masking/fundamental_ransac.h"
#include "masking/mat_checks.h"

namespace dypho {
namespace {

// Mean absolute difference of the patches around a (previous) and b (current), nearest pixels.
double PatchDifference(const cv::Mat& prev, const cv::Mat& cur, const cv::Point2f& a, const cv::Point2f& b,
                       int radius) {
  const int ax = static_cast<int>(std::lround(a.x)), ay = static_cast<int>(std::lround(a.y));
  const int bx = static_cast<int>(std::lround(b.x)), by = static_cast<int>(std::lround(b.y));
  int sum = 0, n = 0;
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      sum += std::abs(prev.at<uint8_t>(ay + dy, ax + dx) - cur.at<uint8_t>(by + dy, bx + dx));
      ++n;
    }
  }
  return static_cast<double>(sum) / n;
}

std::vector<cv::Point2f> Undistort(const std::vector<cv::Point2f>& points, const Camera& camera) {
  if (!camera.HasDistortion() || points.empty()) return points;
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  std::vector<double> dist(camera.distortion.begin(), camera.distortion.end());
  std::vector<cv::Point2f> out;
  cv::undistortPoints(points, out, k, dist, cv::noArray(), k);
  return out;
}

// Our own 7-point RANSAC (fundamental_ransac.h) for EpipolarOptions::method.
constexpr int kFastRansac = -2;

// cv::findFundamentalMat's method for EpipolarOptions::method (kFastRansac
// for ours); -1 for a name it does not have.
int FundamentalMethod(const std::string& name) {
  static const std::pair<const char*, int> kMethods[] = {{"fast_ransac", kFastRansac},
                                                         {"ransac", cv::FM_RANSAC},
                                                         {"lmeds", cv::FM_LMEDS},
                                                         {"magsac", cv::USAC_MAGSAC},
                                                         {"usac_fast", cv::USAC_FAST},
                                                         {"usac_accurate", cv::USAC_ACCURATE}};
  for (const auto& [n, m] : kMethods)
    if (name == n) return m;
  return -1;
}

}  // namespace

bool EpipolarOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (max_features < 8)
    msg << "max_features must be >= 8 (got " << max_features << ")";
  else if (fast_threshold < 1 || fast_threshold > 255)
    msg << "fast_threshold must be in 1..255 (got " << fast_threshold << ")";
  else if (grid_cell_px < 8)
    msg << "grid_cell_px must be >= 8 (got " << grid_cell_px << ")";
  else if (lk_window_px < 5 || lk_window_px > 61 || lk_window_px % 2 == 0)
    msg << "lk_window_px must be odd in 5..61 (got " << lk_window_px << ")";
  else if (lk_levels < 0 || lk_levels > 6)
    msg << "lk_levels must be in 0..6 (got " << lk_levels << ")";
  else if (border_px < 0)
    msg << "border_px must be >= 0 (got " << border_px << ")";
  else if (patch_radius_px < 0 || patch_radius_px > 7)
    msg << "patch_radius_px must be in 0..7 (got " << patch_radius_px << ")";
  else if (!(max_patch_difference > 0))
    msg << "max_patch_difference must be > 0 (got " << max_patch_difference << ")";
  else if (FundamentalMethod(method) == -1)
    msg << "method must be fast_ransac, ransac, lmeds, magsac, usac_fast or usac_accurate (got '" << method << "')";
  else if (!(ransac_threshold_px > 0))
    msg << "ransac_threshold_px must be > 0 (got " << ransac_threshold_px << ")";
  else if (!(ransac_confidence > 0 && ransac_confidence < 1))
    msg << "ransac_confidence must be in (0, 1) (got " << ransac_confidence << ")";
  else if (!(epipolar_threshold_px > 0))
    msg << "epipolar_threshold_px must be > 0 (got " << epipolar_threshold_px << ")";
  else if (min_fit_points < 8)
    msg << "min_fit_points must be >= 8 (got " << min_fit_points << ")";
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

double EpipolarDistance(const cv::Matx33d& f, const cv::Point2d& p1, const cv::Point2d& p2) {
  const cv::Vec3d line = f * cv::Vec3d(p1.x, p1.y, 1.0);  // (A, B, C)
  const double norm = std::hypot(line[0], line[1]);
  if (norm <= 0.0) return 0.0;
  return std::abs(line[0] * p2.x + line[1] * p2.y + line[2]) / norm;
}

EpipolarChecker::EpipolarChecker(const EpipolarOptions& options, const Camera& camera)
    : options_(options), camera_(camera) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "EpipolarOptions." << error;
  camera.Validate("EpipolarChecker");
}

std::vector<cv::Point2f> EpipolarChecker::DetectFeatures(const cv::Mat& gray) const {
  CheckMat(gray, CV_8UC1, cv::Size(camera_.width, camera_.height), "gray");
  const EpipolarOptions& o = options_;
  std::vector<cv::KeyPoint> corners;
  cv::FAST(gray, corners, o.fast_threshold, true);
  // Strongest corners per cell, up to an equal share of max_features.
  const int cell = o.grid_cell_px;
  const int cols = (gray.cols + cell - 1) / cell, rows = (gray.rows + cell - 1) / cell;
  const int per_cell = std::max(1, (o.max_features + cols * rows - 1) / (cols * rows));
  std::stable_sort(corners.begin(), corners.end(),
                   [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
  std::vector<int> used(static_cast<size_t>(cols) * rows, 0);
  const int margin = o.border_px + o.patch_radius_px + 1;
  std::vector<cv::Point2f> points;
  for (const cv::KeyPoint& k : corners) {
    if (static_cast<int>(points.size()) >= o.max_features) break;
    if (k.pt.x < margin || k.pt.y < margin || k.pt.x >= gray.cols - margin || k.pt.y >= gray.rows - margin) continue;
    int& n = used[static_cast<int>(k.pt.y) / cell * cols + static_cast<int>(k.pt.x) / cell];
    if (n >= per_cell) continue;
    ++n;
    points.push_back(k.pt);
  }
  return points;
}

EpipolarResult EpipolarChecker::Check(const cv::Mat& prev_gray, const cv::Mat& gray,
                                      const std::vector<cv::Point2f>& prev_points, const cv::Mat& exclude) const {
  const cv::Size size(camera_.width, camera_.height);
  CheckMat(prev_gray, CV_8UC1, size, "prev_gray");
  CheckMat(gray, CV_8UC1, size, "gray");
  CheckOptionalMat(exclude, CV_8UC1, size, "exclude");
  const EpipolarOptions& o = options_;
  EpipolarResult result;
  result.prev_points = prev_points.empty() ? DetectFeatures(prev_gray) : prev_points;
  const size_t n = result.prev_points.size();
  result.valid.assign(n, 0);
  result.dynamic.assign(n, 0);
  result.distance.assign(n, -1.0f);
  if (n == 0) return result;

  // 1. Pyramidal Lucas-Kanade.
  std::vector<uint8_t> status;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(prev_gray, gray, result.prev_points, result.points, status, error,
                           cv::Size(o.lk_window_px, o.lk_window_px), o.lk_levels,
                           cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01));
  // 2. Border and patch checks.
  const float lo = static_cast<float>(std::max(o.border_px, o.patch_radius_px + 1));
  const float hi_x = gray.cols - 1 - lo, hi_y = gray.rows - 1 - lo;
  auto inside = [&](const cv::Point2f& p) { return p.x >= lo && p.y >= lo && p.x <= hi_x && p.y <= hi_y; };
  std::vector<int> matches;
  for (size_t i = 0; i < n; ++i) {
    if (!status[i] || !inside(result.prev_points[i]) || !inside(result.points[i])) continue;
    if (PatchDifference(prev_gray, gray, result.prev_points[i], result.points[i], o.patch_radius_px) >
        o.max_patch_difference)
      continue;
    result.valid[i] = 1;
    matches.push_back(static_cast<int>(i));
  }
  if (matches.size() < 8) return result;

  // 3. F by RANSAC on undistorted matches outside the exclusion mask.
  std::vector<cv::Point2f> p1_all, p2_all;
  for (int i : matches) {
    p1_all.push_back(result.prev_points[i]);
    p2_all.push_back(result.points[i]);
  }
  p1_all = Undistort(p1_all, camera_);
  p2_all = Undistort(p2_all, camera_);
  std::vector<cv::Point2f> p1_fit, p2_fit;
  for (size_t j = 0; j < matches.size(); ++j) {
    const cv::Point2f& c = result.points[matches[j]];
    if (!exclude.empty() && exclude.at<uint8_t>(static_cast<int>(std::lround(c.y)), static_cast<int>(std::lround(c.x))))
      continue;
    p1_fit.push_back(p1_all[j]);
    p2_fit.push_back(p2_all[j]);
  }
  if (static_cast<int>(p1_fit.size()) < o.min_fit_points) {
    p1_fit = p1_all;
    p2_fit = p2_all;
  }
  result.fit_points = static_cast<int>(p1_fit.size());
  if (FundamentalMethod(o.method) == kFastRansac) {
    const FundamentalFit fit = FitFundamentalRansac(p1_fit, p2_fit, o.ransac_threshold_px, o.ransac_confidence);
    if (!fit.ok) return result;
    result.fundamental = fit.F;
    result.fit_inliers = fit.inliers;
  } else {
    std::vector<uint8_t> inlier_mask;
    const cv::Mat f = cv::findFundamentalMat(p1_fit, p2_fit, FundamentalMethod(o.method), o.ransac_threshold_px,
                                             o.ransac_confidence, inlier_mask);
    if (f.rows != 3 || f.cols != 3) return result;  // RANSAC failed (or returned several solutions)
    result.fundamental = cv::Matx33d(f);
    result.fit_inliers = cv::countNonZero(inlier_mask);
  }
  result.has_fundamental = true;

  // 4. Distance to the epipolar line.
  for (size_t j = 0; j < matches.size(); ++j) {
    const double d = EpipolarDistance(result.fundamental, p1_all[j], p2_all[j]);
    result.distance[matches[j]] = static_cast<float>(d);
    result.dynamic[matches[j]] = d > o.epipolar_threshold_px;
  }
  return result;
}

}  // namespace dypho
