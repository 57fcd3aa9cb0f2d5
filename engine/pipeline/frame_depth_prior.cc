#include "engine/pipeline/frame_depth_prior.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/pipeline/map_depth.h"

namespace dypho {

FrameDepthPrior::FrameDepthPrior(const Camera& camera, const FrameDepthPriorOptions& options)
    : camera_(camera), options_(options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "FrameDepthPriorOptions." << error;
  camera.Validate("FrameDepthPrior camera");
}

double FrameDepthPrior::Distance(const Rigid3d& a, const Rigid3d& b) const {
  const Eigen::Vector3d ca = a.Inverse().translation, cb = b.Inverse().translation;
  return (ca - cb).norm() + options_.rotation_weight * a.rotation.angularDistance(b.rotation);
}

bool FrameDepthPrior::Offer(const cv::Mat& depth, const cv::Mat& mask, const Rigid3d& cam_from_world) {
  DYPHO_CHECK_INPUT(depth.type() == CV_32FC1 && !depth.empty()) << "FrameDepthPrior: depth must be CV_32FC1";
  DYPHO_CHECK_INPUT(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == depth.size()))
      << "FrameDepthPrior: the mask must be CV_8UC1 of the depth's size";
  double nearest = 1e300;
  size_t farthest = 0;
  double farthest_d = -1.0;
  for (size_t i = 0; i < kept_.size(); ++i) {
    const double d = Distance(kept_[i].cam_from_world, cam_from_world);
    nearest = std::min(nearest, d);
    if (d > farthest_d) {
      farthest_d = d;
      farthest = i;
    }
  }
  if (!kept_.empty() && nearest < options_.spacing) return false;
  const cv::Size size(camera_.width, camera_.height);
  Kept k;
  k.cam_from_world = cam_from_world;
  if (depth.size() == size) {
    k.depth = depth.clone();
  } else {
    cv::resize(depth, k.depth, size, 0, 0, cv::INTER_NEAREST);
  }
  if (!mask.empty()) {
    // A render pixel is dynamic when any image pixel under it is (INTER_AREA
    // then > 0), grown by the margin.
    cv::Mat small;
    if (mask.size() == size) {
      small = mask;
    } else {
      cv::resize(mask, small, size, 0, 0, cv::INTER_AREA);
    }
    cv::Mat dynamic = small > 0;
    if (options_.mask_margin_px > 0) {
      const int r = options_.mask_margin_px;
      cv::dilate(dynamic, dynamic, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
    }
    k.depth.setTo(0.0f, dynamic);
  }
  if (static_cast<int>(kept_.size()) < options_.max_frames) {
    kept_.push_back(std::move(k));
  } else {
    kept_[farthest] = std::move(k);
  }
  return true;
}

cv::Mat FrameDepthPrior::Prior(const Rigid3d& cam_from_world) const {
  if (kept_.empty()) return cv::Mat();
  std::vector<size_t> order(kept_.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::vector<double> d(kept_.size());
  for (size_t i = 0; i < kept_.size(); ++i) d[i] = Distance(kept_[i].cam_from_world, cam_from_world);
  // Ties by position in the store: deterministic.
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return d[a] < d[b]; });
  const size_t n = std::min(order.size(), static_cast<size_t>(options_.fuse));
  std::vector<cv::Mat> warped(n);
  for (size_t j = 0; j < n; ++j) {
    const Kept& k = kept_[order[j]];
    warped[j] = WarpMapDepth(k.depth, camera_, cam_from_world * k.cam_from_world.Inverse());
  }
  // Per pixel: the nearest frame's depth that `min_agree` other frames
  // confirm (within tolerance_abs + tolerance_rel z^2).
  cv::Mat out(camera_.height, camera_.width, CV_32FC1, cv::Scalar(0.0f));
  const float ta = static_cast<float>(options_.tolerance_abs), tr = static_cast<float>(options_.tolerance_rel);
  for (int y = 0; y < out.rows; ++y) {
    float* o = out.ptr<float>(y);
    for (int x = 0; x < out.cols; ++x) {
      for (size_t j = 0; j < n; ++j) {
        const float z = warped[j].ptr<float>(y)[x];
        if (z <= 0.0f) continue;
        const float tol = ta + tr * z * z;
        int agree = 0;
        for (size_t i = 0; i < n; ++i) {
          if (i == j) continue;
          const float w = warped[i].ptr<float>(y)[x];
          if (w > 0.0f && std::abs(w - z) <= tol) ++agree;
        }
        if (agree >= options_.min_agree) {
          o[x] = z;
          break;
        }
      }
    }
  }
  return out;
}

void FrameDepthPrior::Clear() { kept_.clear(); }

}  // namespace dypho
