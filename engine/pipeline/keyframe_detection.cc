#include "engine/pipeline/keyframe_detection.h"

#include <opencv2/imgproc.hpp>

#include <cstdio>

#include "common/check.h"
#include "common/files.h"
#include "engine/io/image_io.h"
#include "engine/map/keyframe_selector.h"

namespace dypho {

KeyframeDetection::KeyframeDetection(const SegmenterOptions& options, const Camera& camera, int mask_downscale,
                                     std::optional<BackgroundOptions> refine)
    : segmenter_(CreateSegmenter(options)), camera_(camera), downscale_(mask_downscale), refine_(std::move(refine)) {
  DYPHO_CHECK_INPUT(mask_downscale >= 1) << "KeyframeDetection: mask_downscale must be >= 1";
  if (refine_) {
    std::string error;
    DYPHO_CHECK_INPUT(refine_->IsValid(&error)) << "KeyframeDetection: BackgroundOptions." << error;
    refine_->add_dynamic = false;
  }
}

KeyframeDetection::~KeyframeDetection() = default;

void KeyframeDetection::Note(double timestamp, const std::string& name, bool fresh, const cv::Mat& background,
                             const cv::Mat& support) {
  Noted noted{name, fresh, cv::Mat(), cv::Mat()};
  if (refine_ && !fresh && !background.empty()) {
    DYPHO_CHECK_INPUT(background.type() == CV_32FC1 && support.type() == CV_8UC1 &&
                      background.size() == support.size())
        << "KeyframeDetection::Note: the background must be CV_32FC1 and its support CV_8UC1 of the same size";
    // Shared, not copied: the background model makes a new B and S each
    // frame and never writes them afterwards (nothing on the tracking
    // thread's path).
    noted.background = background;
    noted.support = support;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  noted_[timestamp] = std::move(noted);
  while (noted_.size() > kKeyframeCandidateFrames) noted_.erase(noted_.begin());
  if (noted_.size() > kBackgroundFrames) {
    auto old = std::prev(noted_.end(), static_cast<long>(kBackgroundFrames) + 1);
    old->second.background.release();
    old->second.support.release();
  }
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

int KeyframeDetection::refined() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return refined_;
}

long KeyframeDetection::refined_pixels() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return refined_pixels_;
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
  cv::Mat mask = seg.mask;
  int removed = -1;  // -1 = not refined
  if (refine_ && !noted.background.empty() && !input.depth.empty() && noted.background.size() == mask.size() &&
      input.depth.size() == mask.size()) {
    BackgroundRefinement r = RefineMask(input.depth, mask, noted.background, noted.support, *refine_);
    mask = r.refined_mask;
    removed = r.removed_pixels;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++runs_;
    if (removed >= 0) {
      ++refined_;
      refined_pixels_ += removed;
    }
  }
  cv::Mat full = mask;
  if (mask.size() != rgb.size()) cv::resize(mask, full, rgb.size(), 0, 0, cv::INTER_NEAREST);
  if (!full.isContinuous()) full = full.clone();
  return std::vector<uint8_t>(full.datastart, full.dataend);
}

std::function<std::vector<uint8_t>(const KeyframeMaskRequest&)> KeyframeMaskHook(
    std::shared_ptr<KeyframeDetection> detection, const std::string& folder) {
  if (!folder.empty()) MakeDirectories(folder);
  return [detection, folder](const KeyframeMaskRequest& r) {
    std::vector<uint8_t> extra = detection ? (*detection)(r) : std::vector<uint8_t>();
    if (!folder.empty()) {
      ImageU8 mask(r.width, r.height, 1);
      const size_t n = static_cast<size_t>(r.width) * r.height;
      for (size_t i = 0; i < n; ++i) {
        const bool pushed = r.dynamic_mask != nullptr && r.dynamic_mask[i] != 0;
        const bool fresh = !extra.empty() && extra[i] != 0;
        mask.data()[i] = pushed || fresh ? 255 : 0;
      }
      char name[64];
      std::snprintf(name, sizeof(name), "/%.6f.png", r.timestamp);
      WriteGray8(folder + name, mask);
    }
    return extra;
  };
}

}  // namespace dypho
