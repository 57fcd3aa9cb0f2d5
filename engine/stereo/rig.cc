#include "engine/stereo/rig.h"

#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"

namespace dypho::stereo {
namespace {

cv::Mat K(const Camera& c) {
  return (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
}

cv::Mat D(const Camera& c) {
  return (cv::Mat_<double>(1, 5) << c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3],
          c.distortion[4]);
}

}  // namespace

bool IsRectified(const StereoCalibration& s) {
  const double kEps = 1e-6;
  const auto same = [&](double a, double b) { return std::abs(a - b) <= kEps * std::max(1.0, std::abs(a)); };
  const Eigen::Vector3d& t = s.right_from_left_translation;
  return !s.left.HasDistortion() && !s.right.HasDistortion() && same(s.left.fx, s.right.fx) &&
         same(s.left.fy, s.right.fy) && same(s.left.cx, s.right.cx) && same(s.left.cy, s.right.cy) &&
         (s.right_from_left_rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= kEps &&
         std::abs(t.y()) <= kEps && std::abs(t.z()) <= kEps;
}

StereoRig MakeRig(const StereoCalibration& s) {
  s.left.ValidateCalibration(s.source + ": left camera");
  s.right.ValidateCalibration(s.source + ": right camera");
  DYPHO_CHECK_INPUT(s.left.width == s.right.width && s.left.height == s.right.height)
      << s.source << ": the cameras differ in size (left " << s.left.width << "x" << s.left.height << ", right "
      << s.right.width << "x" << s.right.height << ")";
  DYPHO_CHECK_INPUT(s.right_from_left_rotation.allFinite() && s.right_from_left_translation.allFinite())
      << s.source << ": the right-from-left transform has non-finite numbers";
  const double norm = s.right_from_left_translation.norm();
  DYPHO_CHECK_INPUT(norm > 1e-6) << s.source << ": zero baseline (the cameras are at one place)";
  StereoRig rig;
  rig.source = s.source;
  if (IsRectified(s)) {
    rig.camera = s.left;
    rig.baseline = -s.right_from_left_translation.x();
    DYPHO_CHECK_INPUT(rig.baseline > 0) << s.source << ": the right camera is not to the right of the left one "
                                        << "(right-from-left tx = " << s.right_from_left_translation.x()
                                        << " m; expected < 0)";
    return rig;
  }
  cv::Mat R, T, R1, R2, P1, P2, Q;
  cv::eigen2cv(s.right_from_left_rotation, R);
  cv::eigen2cv(s.right_from_left_translation, T);
  const cv::Size size(s.left.width, s.left.height);
  cv::stereoRectify(K(s.left), D(s.left), K(s.right), D(s.right), size, R, T, R1, R2, P1, P2, Q,
                    cv::CALIB_ZERO_DISPARITY, 0, size);
  rig.rectify = true;
  rig.camera.fx = P1.at<double>(0, 0), rig.camera.fy = P1.at<double>(1, 1);
  rig.camera.cx = P1.at<double>(0, 2), rig.camera.cy = P1.at<double>(1, 2);
  rig.camera.width = s.left.width, rig.camera.height = s.left.height;
  rig.baseline = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
  DYPHO_CHECK_INPUT(std::abs(P2.at<double>(1, 3)) < 1e-6 * std::abs(P2.at<double>(0, 3)))
      << s.source << ": the cameras are stacked vertically; a horizontal stereo pair is needed";
  DYPHO_CHECK_INPUT(rig.baseline > 0) << s.source << ": the right camera is not to the right of the left one "
                                      << "(rectified baseline " << rig.baseline << " m)";
  cv::cv2eigen(R1, rig.rectified_from_left);
  cv::initUndistortRectifyMap(K(s.left), D(s.left), R1, P1, size, CV_32FC1, rig.map_left_x, rig.map_left_y);
  cv::initUndistortRectifyMap(K(s.right), D(s.right), R2, P2, size, CV_32FC1, rig.map_right_x, rig.map_right_y);
  rig.camera.ValidateCalibration(s.source + ": rectified camera");
  return rig;
}

void RectifyPair(const StereoRig& rig, cv::Mat& left, cv::Mat& right) {
  if (!rig.rectify) return;
  cv::Mat l, r;
  cv::remap(left, l, rig.map_left_x, rig.map_left_y, cv::INTER_LINEAR);
  cv::remap(right, r, rig.map_right_x, rig.map_right_y, cv::INTER_LINEAR);
  left = l, right = r;
}

}  // namespace dypho::stereo
