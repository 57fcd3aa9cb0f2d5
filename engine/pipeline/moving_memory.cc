#include "engine/pipeline/moving_memory.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/pipeline/frame_masks.h"

namespace dypho {

MovingMemory::MovingMemory(const MovingMemoryOptions& options, const Camera& camera)
    : options_(options), camera_(camera) {
  DYPHO_CHECK_INPUT(options.frames >= 1) << "moving memory: frames must be >= 1, got " << options.frames;
  DYPHO_CHECK_INPUT(options.stride_px >= 1) << "moving memory: stride_px must be >= 1, got " << options.stride_px;
  DYPHO_CHECK_INPUT(options.radius_px >= 0.0) << "moving memory: radius_px must be >= 0, got " << options.radius_px;
  DYPHO_CHECK_INPUT(options.min_overlap > 0.0 && options.min_overlap <= 1.0)
      << "moving memory: min_overlap must be in (0, 1], got " << options.min_overlap;
  DYPHO_CHECK_INPUT(options.min_component_px >= 0)
      << "moving memory: min_component_px must be >= 0, got " << options.min_component_px;
  DYPHO_CHECK_INPUT(camera.width > 0 && camera.height > 0) << "moving memory: camera has no size";
}

void MovingMemory::Add(const cv::Mat& mover_mask, const cv::Mat& depth, const Rigid3d& cam_from_world) {
  DYPHO_CHECK_INPUT(mover_mask.type() == CV_8UC1 && mover_mask.cols == camera_.width &&
                    mover_mask.rows == camera_.height)
      << "moving memory: mover_mask must be CV_8UC1 of the camera's size";
  DYPHO_CHECK_INPUT(depth.type() == CV_32FC1 && !depth.empty()) << "moving memory: depth must be CV_32FC1";
  const double sx = static_cast<double>(depth.cols) / mover_mask.cols;
  const double sy = static_cast<double>(depth.rows) / mover_mask.rows;
  const Rigid3d world_from_cam = cam_from_world.Inverse();
  std::vector<Eigen::Vector3f> points;
  const int s = options_.stride_px;
  for (int y = s / 2; y < mover_mask.rows; y += s) {
    const uint8_t* m = mover_mask.ptr<uint8_t>(y);
    const int dy = std::min(depth.rows - 1, static_cast<int>(y * sy));
    const float* d = depth.ptr<float>(dy);
    for (int x = s / 2; x < mover_mask.cols; x += s) {
      if (!m[x]) continue;
      const float z = d[std::min(depth.cols - 1, static_cast<int>(x * sx))];
      if (!(z > 0.0f) || !std::isfinite(z)) continue;
      const Eigen::Vector2d ideal = camera_.Undistort(Eigen::Vector2d(x, y));
      points.push_back((world_from_cam * camera_.Unproject(ideal, z)).cast<float>());
    }
  }
  frames_.push_back(std::move(points));
  while (static_cast<int>(frames_.size()) > options_.frames) frames_.pop_front();
}

cv::Mat MovingMemory::Project(const Rigid3d& cam_from_world) const {
  // The points are plotted on a canvas padded by the radius (a point just
  // outside the image still covers its edge), then every pixel within
  // radius_px of a plotted one is covered: one exact Euclidean distance
  // transform instead of a disc per point (150k points: 23 ms as discs).
  const int r = static_cast<int>(std::lround(options_.radius_px));
  const int w = camera_.width, h = camera_.height;
  cv::Mat canvas(h + 2 * r, w + 2 * r, CV_8UC1, cv::Scalar(255));  // 0 = a point
  for (const std::vector<Eigen::Vector3f>& frame : frames_) {
    for (const Eigen::Vector3f& p : frame) {
      const Eigen::Vector3d c = cam_from_world * p.cast<double>();
      if (c.z() <= 1e-3) continue;
      const Eigen::Vector2d px = camera_.Distort(camera_.Project(c));
      const int x = static_cast<int>(std::lround(px.x())), y = static_cast<int>(std::lround(px.y()));
      if (x < -r || y < -r || x >= w + r || y >= h + r) continue;
      canvas.at<uint8_t>(y + r, x + r) = 0;
    }
  }
  cv::Mat distance;
  cv::distanceTransform(canvas, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  cv::Mat covered;
  cv::compare(distance(cv::Rect(r, r, w, h)), options_.radius_px, covered, cv::CMP_LE);
  return covered;
}

cv::Mat MovingMemory::Confirm(const cv::Mat& flow_only, const Rigid3d& cam_from_world) const {
  DYPHO_CHECK_INPUT(flow_only.type() == CV_8UC1 && flow_only.cols == camera_.width && flow_only.rows == camera_.height)
      << "moving memory: flow_only must be CV_8UC1 of the camera's size";
  cv::Mat confirmed(flow_only.size(), CV_8UC1, cv::Scalar(0));
  if (frames_.empty() || cv::countNonZero(flow_only) == 0) return confirmed;
  const cv::Mat covered = Project(cam_from_world);
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(flow_only, labels, stats, centroids, 8, CV_32S);
  std::vector<int> hits(static_cast<size_t>(n), 0);
  for (int y = 0; y < labels.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    const uint8_t* c = covered.ptr<uint8_t>(y);
    for (int x = 0; x < labels.cols; ++x)
      if (l[x] > 0 && c[x]) ++hits[static_cast<size_t>(l[x])];
  }
  std::vector<uint8_t> keep(static_cast<size_t>(n), 0);
  for (int i = 1; i < n; ++i) {
    const int area = stats.at<int>(i, cv::CC_STAT_AREA);
    keep[static_cast<size_t>(i)] = area >= options_.min_component_px && hits[static_cast<size_t>(i)] >= options_.min_overlap * area;
  }
  for (int y = 0; y < labels.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    uint8_t* o = confirmed.ptr<uint8_t>(y);
    for (int x = 0; x < labels.cols; ++x)
      if (keep[static_cast<size_t>(l[x])]) o[x] = 255;
  }
  return confirmed;
}

size_t MovingMemory::points() const {
  size_t n = 0;
  for (const auto& f : frames_) n += f.size();
  return n;
}

cv::Mat FlowOnlyPixels(const MaskResult& masks) {
  if (!masks.flow_computed || masks.flow_mask.empty()) return cv::Mat(masks.mask.size(), CV_8UC1, cv::Scalar(0));
  const cv::Mat flow_only = UpscaledMask(masks.flow_mask & ~masks.semantic_mask, masks.mask.size());
  return flow_only & masks.mask;  // what the refinement cleared is not in the final mask
}

cv::Mat MapMask(const MaskResult& masks, const std::string& mode, MovingMemory* memory, const cv::Mat& depth,
                const Rigid3d& cam_from_world) {
  DYPHO_CHECK_INPUT(mode == "all" || mode == "none" || mode == "confirmed")
      << "map_flow_mask must be all, none or confirmed, got '" << mode << "'";
  if (mode == "all" && !memory) return masks.mask;
  const cv::Mat flow_only = FlowOnlyPixels(masks);
  // New images throughout: assigning an expression to a cv::Mat that shares
  // masks.mask's buffer would write into the caller's final mask.
  cv::Mat map_mask;
  if (mode == "none") {
    map_mask = masks.mask & ~flow_only;
  } else if (mode == "confirmed") {
    const cv::Mat dropped = memory ? cv::Mat(flow_only & ~memory->Confirm(flow_only, cam_from_world)) : flow_only;
    map_mask = masks.mask & ~dropped;
  } else {
    map_mask = masks.mask;
  }
  if (memory && !depth.empty()) {
    if (mode == "confirmed" && memory->options().remember_confirmed)
      memory->Add(map_mask, depth, cam_from_world);
    else
      memory->Add(masks.mask & ~flow_only, depth, cam_from_world);
  }
  return map_mask;
}

}  // namespace dypho
