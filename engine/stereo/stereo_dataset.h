// Stereo sequences as datasets: the readers of the KITTI odometry, EuRoC/ASL
// and generic stereo layouts, and the frame loader that turns a rectified pair
// into an RGB-D frame (depth from dense disparity), so that everything after
// the dataset sees RGB-D plus the right image.
//
// Layouts (detected in this order):
//   KITTI odometry: calib.txt (lines "P0: 12 numbers", "P1: ..."; P2/P3 for
//     colour), image_0/ + image_1/ (grey) or image_2/ + image_3/ (colour),
//     optional times.txt (one time [s] a line, one per frame; absent: 10 Hz),
//     optional poses.txt (KITTI: 12 numbers a line, the row-major 3x4
//     world_from_cam0, one per frame). Rectified by definition.
//   EuRoC/ASL: mav0/cam0/ and mav0/cam1/, each with data.csv ("timestamp [ns],
//     file name" lines), data/ and sensor.yaml (resolution, intrinsics
//     [fu fv cu cv], distortion_coefficients [k1 k2 p1 p2], T_BS 4x4 body from
//     sensor); optional mav0/state_groundtruth_estimate0/data.csv (timestamp
//     [ns], position, quaternion w x y z of the body). Rectified here.
//   generic: left/ and right/ (images named alike, sorted by name) and a
//     stereo.yaml: width, height, left and right {fx, fy, cx, cy, optional
//     distortion [k1 k2 p1 p2 k3]}, right_from_left {rotation: 9 numbers
//     row-major, translation: [tx ty tz] metres}, optional frame_rate [Hz];
//     optional groundtruth.txt (TUM format, world_from_left). Rectified when
//     the calibration is not already rectified (rig.h, IsRectified).
// Errors name the file and line (a missing right image, sizes that disagree,
// zero baseline, non-finite numbers).
#pragma once

#include <optional>
#include <string>

#include "engine/dataset/dataset.h"
#include "engine/stereo/rig.h"

namespace dypho::stereo {

// The stereo layout in `folder`, or nullopt when it holds none.
std::optional<Dataset::Contents> OpenStereoContents(const std::string& folder, const DatasetOptions& options);

// Reads, rectifies and matches a frame's pair; depth (metres) where the
// disparity was matched (confidence > 0) and >= rig.min_disparity_for_depth
// (pair_depth.h; a preview when rig.preview_downscale > 1).
Frame LoadStereoFrame(const StereoRig& rig, const FrameInfo& info);

// KITTI poses file (12 numbers a line) with the times of times.txt as a TUM
// trajectory; throws naming file and line on a malformed line or a count mismatch.
Trajectory ReadKittiPoses(const std::string& poses_path, const std::vector<double>& times);
// times.txt: one number a line.
std::vector<double> ReadKittiTimes(const std::string& path);

namespace internal {
std::optional<Dataset::Contents> OpenKitti(const std::string& folder);
std::optional<Dataset::Contents> OpenEuroc(const std::string& folder, const DatasetOptions& options);
std::optional<Dataset::Contents> OpenGenericStereo(const std::string& folder, const DatasetOptions& options);
// Size of an image file (decodes it); throws naming it when unreadable.
cv::Size ImageSize(const std::string& path);
// Fills the right image of every frame and checks that it exists.
void CheckPairsExist(const Dataset::Contents& contents);
}  // namespace internal

}  // namespace dypho::stereo
