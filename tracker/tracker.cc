#include "tracker/tracker.h"

#include <cmath>

#include "common/check.h"

namespace dypho {

const char* TrackStatusName(TrackStatus status) {
  switch (status) {
    case TrackStatus::kInitializing:
      return "initializing";
    case TrackStatus::kOk:
      return "ok";
    case TrackStatus::kRelocalized:
      return "relocalized";
    case TrackStatus::kLost:
      return "lost";
  }
  return "unknown";
}

const char* CoarseSourceName(CoarseSource source) {
  switch (source) {
    case CoarseSource::kNone:
      return "none";
    case CoarseSource::kStart:
      return "start";
    case CoarseSource::kLastFrame:
      return "last frame";
    case CoarseSource::kReferenceKeyframe:
      return "reference keyframe";
    case CoarseSource::kRelocalisation:
      return "relocalisation";
  }
  return "unknown";
}

void CheckTrackerFrame(const TrackerFrame& frame, const Camera& camera) {
  DYPHO_CHECK_INPUT(std::isfinite(frame.timestamp)) << "tracker frame: timestamp is not finite";
  DYPHO_CHECK_INPUT(!frame.image.empty()) << "tracker frame at t=" << frame.timestamp << ": image is empty";
  DYPHO_CHECK_INPUT(frame.image.type() == CV_8UC3 || frame.image.type() == CV_8UC1)
      << "tracker frame at t=" << frame.timestamp << ": image must be CV_8UC3 (RGB) or CV_8UC1 (got type "
      << frame.image.type() << ")";
  DYPHO_CHECK_INPUT(frame.image.cols == camera.width && frame.image.rows == camera.height)
      << "tracker frame at t=" << frame.timestamp << ": image is " << frame.image.cols << "x" << frame.image.rows
      << " but the camera is " << camera.width << "x" << camera.height;
  auto check = [&](const cv::Mat& m, int type, const char* name, const char* type_name) {
    if (m.empty()) return;
    DYPHO_CHECK_INPUT(m.type() == type) << "tracker frame at t=" << frame.timestamp << ": " << name << " must be "
                                        << type_name << " (got type " << m.type() << ")";
    DYPHO_CHECK_INPUT(m.cols == camera.width && m.rows == camera.height)
        << "tracker frame at t=" << frame.timestamp << ": " << name << " is " << m.cols << "x" << m.rows
        << " but the camera is " << camera.width << "x" << camera.height;
  };
  check(frame.depth, CV_32FC1, "depth", "CV_32FC1 [m]");
  if (!frame.right_image.empty()) {
    DYPHO_CHECK_INPUT(frame.right_image.type() == CV_8UC3 || frame.right_image.type() == CV_8UC1)
        << "tracker frame at t=" << frame.timestamp << ": right_image must be CV_8UC3 (RGB) or CV_8UC1 (got type "
        << frame.right_image.type() << ")";
    DYPHO_CHECK_INPUT(frame.right_image.cols == camera.width && frame.right_image.rows == camera.height)
        << "tracker frame at t=" << frame.timestamp << ": right_image is " << frame.right_image.cols << "x"
        << frame.right_image.rows << " but the camera is " << camera.width << "x" << camera.height;
  }
  if (!frame.stereo_prior_depth.empty()) {
    const cv::Mat& p = frame.stereo_prior_depth;
    const int n = p.cols > 0 ? camera.width / p.cols : 0;
    DYPHO_CHECK_INPUT(p.type() == CV_32FC1 && n >= 1 && p.cols * n == camera.width && p.rows * n == camera.height)
        << "tracker frame at t=" << frame.timestamp << ": stereo_prior_depth is " << p.cols << "x" << p.rows
        << " (type " << p.type() << ") but must be CV_32FC1 with the camera size " << camera.width << "x"
        << camera.height << " divided by an integer";
  }
  check(frame.dynamic_mask, CV_8UC1, "dynamic_mask", "CV_8UC1");
  check(frame.static_weight, CV_32FC1, "static_weight", "CV_32FC1");
}

}  // namespace dypho
