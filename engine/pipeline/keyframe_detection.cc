#include "engine/pipeline/keyframe_detection.h"

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/map/keyframe_selector.h"

namespace dypho {

KeyframeDetection::KeyframeDetection(const SegmenterOptions& options, const Camera& camera, int mask_downscale)
    : segmenter_(CreateSegmenter(options)), camera_(camera), downscale_(mask_downscale) {
  DYPHO_CHECK_INPUT(mask_downscale >= 1) << "KeyframeDetection: mask_downscale must be >= 1";
}

KeyframeDetection::~KeyframeDetection() = default;

void KeyframeDetection::Note(double timestamp, const std::string& name, bool fresh) {
  std::lock_guard<std::mutex> lock(mutex_);
  noted_[timestamp] = Noted{name, fresh};
  while (noted_.size() > kKeyframeCandidateFrames) noted_.erase(noted_.begin());
}

void KeyframeDetection::Claim(double timestamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = noted_.find(timestamp);
  if (it == noted_.end() || it->second.fresh) return;  // nothing to run for it
  claimed_[timestamp] = it->second;
}

int KeyframeDetection::runs() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return runs_;
}

std::vector<uint8_t> KeyframeDetection::operator()(const KeyframeMaskRequest& request) {
  Noted noted;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (const auto it = claimed_.find(request.timestamp); it != claimed_.end()) {
      noted = std::move(it->second);
      claimed_.erase(it);
    } else if (const auto jt = noted_.find(request.timestamp); jt != noted_.end()) {
      noted = jt->second;  // a keyframe emitted at the end of the stream (never claimed)
    } else {
      return {};
    }
  }
  if (noted.fresh) return {};
  DYPHO_CHECK_INPUT(request.width == camera_.width && request.height == camera_.height && request.rgb != nullptr)
      << "KeyframeDetection: the request is " << request.width << "x" << request.height << ", the camera "
      << camera_.width << "x" << camera_.height;
  const cv::Mat rgb(request.height, request.width, CV_8UC3, const_cast<uint8_t*>(request.rgb));
  const cv::Mat depth = request.depth_m == nullptr
                            ? cv::Mat()
                            : cv::Mat(request.height, request.width, CV_32FC1, const_cast<float*>(request.depth_m));
  SegmenterInput input;
  input.name = noted.name;
  if (downscale_ == 1) {
    input.rgb = rgb;
    input.depth = depth;
  } else {
    const cv::Size small(request.width / downscale_, request.height / downscale_);
    cv::resize(rgb, input.rgb, small, 0, 0, cv::INTER_AREA);
    if (!depth.empty()) cv::resize(depth, input.depth, small, 0, 0, cv::INTER_NEAREST);
  }
  Segmentation seg;
  {
    // Notes (the tracking thread) go on meanwhile; one segmentation at a time.
    std::lock_guard<std::mutex> lock(segment_mutex_);
    seg = segmenter_->Segment(input);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++runs_;
  }
  cv::Mat mask = seg.mask;
  if (mask.size() != rgb.size()) cv::resize(seg.mask, mask, rgb.size(), 0, 0, cv::INTER_NEAREST);
  if (!mask.isContinuous()) mask = mask.clone();
  return std::vector<uint8_t>(mask.datastart, mask.dataend);
}

}  // namespace dypho
