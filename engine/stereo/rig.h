// A calibrated stereo rig, rectified once per sequence.
#pragma once

#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "common/camera.h"
#include "engine/stereo/disparity.h"

namespace dypho::stereo {

// Both cameras (intrinsics, distortion, size) and the rigid transform that maps
// left-camera coordinates to right-camera ones (x_right = R x_left + t, metres).
struct StereoCalibration {
  Camera left, right;
  Eigen::Matrix3d right_from_left_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d right_from_left_translation = Eigen::Vector3d::Zero();
  std::string source;  // where it was read, for messages ("calib.txt", "mav0/cam1/sensor.yaml")
};

struct StereoRig {
  Camera camera;          // the rectified left camera (no distortion): the dataset's camera
  double baseline = 0;    // [m], > 0
  bool rectify = false;   // false: the pair is already rectified (maps empty)
  cv::Mat map_left_x, map_left_y, map_right_x, map_right_y;  // cv::remap maps (CV_32F)
  // rectified_left_from_left: rotation of the rectified left camera (identity without rectification).
  Eigen::Matrix3d rectified_from_left = Eigen::Matrix3d::Identity();
  DisparityOptions disparity;
  double min_disparity_for_depth = 1.0;  // [px] smaller disparities give no depth
  // >1: the frame loader's depth is a preview from the disparity of the pair
  // downscaled by this factor (about 1/factor^2 of the cost), upsampled to
  // the camera size; the dense depth of the full pair is left to whoever
  // needs it (the engine computes it for keyframes: FrameBuffers::
  // keyframe_depth_from_pair). 1 = the full dense depth for every frame.
  int preview_downscale = 1;
  std::string source;
};

// True when the calibration describes a rectified pair: no distortion, equal
// intrinsics, no rotation and a purely horizontal translation (to 1e-6).
bool IsRectified(const StereoCalibration& calibration);

// Validates (finite numbers, plausible cameras, equal sizes, baseline > 0;
// InvalidInput naming calibration.source) and builds the rig: the calibration
// itself when it is rectified, else cv::stereoRectify (zero-disparity principal
// points, alpha 0) and the cv::initUndistortRectifyMap maps of both cameras.
StereoRig MakeRig(const StereoCalibration& calibration);

// Rectifies (when the rig says so) a pair read from disk.
void RectifyPair(const StereoRig& rig, cv::Mat& left, cv::Mat& right);

}  // namespace dypho::stereo
