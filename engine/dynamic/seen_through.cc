#include "engine/dynamic/seen_through.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "common/check.h"

namespace dypho {

void SeenThroughOptions::Validate() const {
  DYPHO_CHECK_INPUT(window >= 1 && window <= 1000) << "seen_through.window must be in [1, 1000] (got " << window << ")";
  DYPHO_CHECK_INPUT(neighbours >= 1 && neighbours <= 2 * window)
      << "seen_through.neighbours must be in [1, 2 * window] (got " << neighbours << ")";
  DYPHO_CHECK_INPUT(votes >= 1 && votes <= neighbours)
      << "seen_through.votes must be in [1, neighbours] (got " << votes << ")";
  DYPHO_CHECK_INPUT(downscale >= 1 && downscale <= 32) << "seen_through.downscale must be in [1, 32] (got " << downscale << ")";
  DYPHO_CHECK_INPUT(std::isfinite(margin_m) && margin_m >= 0) << "seen_through.margin_m must be >= 0 (got " << margin_m << ")";
  DYPHO_CHECK_INPUT(std::isfinite(margin_rel) && margin_rel >= 0)
      << "seen_through.margin_rel must be >= 0 (got " << margin_rel << ")";
  DYPHO_CHECK_INPUT(edge_blocks >= 0 && edge_blocks <= 16)
      << "seen_through.edge_blocks must be in [0, 16] (got " << edge_blocks << ")";
  DYPHO_CHECK_INPUT(std::isfinite(readout) && readout >= 0 && readout < 1)
      << "seen_through.readout must be in [0, 1) s (got " << readout << ")";
  DYPHO_CHECK_INPUT(dilate >= 0 && dilate <= 64) << "seen_through.dilate must be in [0, 64] (got " << dilate << ")";
}

namespace {

bool Valid(float d) { return std::isfinite(d) && d > 0.0f; }

// Each pixel's smallest valid depth over its (2r+1)^2 neighbourhood (0 = none).
ImageF MinAround(const ImageF& in, int r) {
  const int w = in.width(), h = in.height();
  ImageF out(w, h, 1, 0.0f);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float best = std::numeric_limits<float>::infinity();
      for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy)
        for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx) {
          const float d = in.at(xx, yy);
          if (d > 0.0f && d < best) best = d;
        }
      out.at(x, y) = std::isfinite(best) ? best : 0.0f;
    }
  }
  return out;
}

}  // namespace

ImageF MinPoolDepth(const ImageF& depth, int downscale) {
  DYPHO_CHECK_INPUT(downscale >= 1) << "MinPoolDepth: downscale must be >= 1 (got " << downscale << ")";
  const int w = (depth.width() + downscale - 1) / downscale, h = (depth.height() + downscale - 1) / downscale;
  ImageF out(w, h, 1, 0.0f);
  for (int y = 0; y < depth.height(); ++y) {
    for (int x = 0; x < depth.width(); ++x) {
      const float d = depth.at(x, y);
      if (!Valid(d)) continue;
      float& o = out.at(x / downscale, y / downscale);
      if (o == 0.0f || d < o) o = d;
    }
  }
  return out;
}

ImageU8 SeenThroughMask(const Camera& camera, const ImageF& depth, const Rigid3d& cam_from_world,
                        const std::vector<const DepthAtPose*>& others, const SeenThroughOptions& options,
                        const Eigen::Vector3d& omega) {
  const int w = depth.width(), h = depth.height();
  DYPHO_CHECK_INPUT(w == camera.width && h == camera.height)
      << "SeenThroughMask: depth is " << w << "x" << h << ", the camera " << camera.width << "x" << camera.height;
  ImageU8 mask(w, h, 1, 0);
  if (others.empty()) return mask;
  std::vector<uint16_t> votes(static_cast<size_t>(w) * h, 0);  // up to neighbours (<= 2000) each
  const double f = options.downscale;
  const Rigid3d world_from_cam = cam_from_world.Inverse();
  for (const DepthAtPose* other : others) {
    const ImageF& od = other->depth;
    const int ow = od.width(), oh = od.height();
    DYPHO_CHECK(ow == (w + options.downscale - 1) / options.downscale &&
                oh == (h + options.downscale - 1) / options.downscale)
        << "SeenThroughMask: a neighbour's depth is " << ow << "x" << oh;
    const Rigid3d other_from_cam = other->cam_from_world * world_from_cam;
    const Eigen::Matrix3f r = other_from_cam.rotation.toRotationMatrix().cast<float>();
    const Eigen::Vector3f t = other_from_cam.translation.cast<float>();
    // The neighbour's pixel grid scaled to its blocks.
    const float fx = static_cast<float>(camera.fx / f), fy = static_cast<float>(camera.fy / f);
    const float cx = static_cast<float>((camera.cx + 0.5) / f - 0.5), cy = static_cast<float>((camera.cy + 0.5) / f - 0.5);
    // Rolling shutter, to first order in the row's rotation (|omega tau| is
    // at most a few hundredths of a radian): the keyframe's row camera back
    // to its frame camera, then the neighbour's frame camera to the row that
    // sees the point (found by fixed-point steps below).
    const bool rolling = options.readout > 0;
    const float tau_per_row = rolling ? static_cast<float>(options.readout / std::max(1, h - 1)) : 0.0f;
    const Eigen::Vector3f key_omega = omega.cast<float>(), other_omega = other->omega.cast<float>();
    for (int y = 0; y < h; ++y) {
      const float b = static_cast<float>((y - camera.cy) / camera.fy);
      const Eigen::Vector3f key_w = key_omega * (tau_per_row * (y - 0.5f * (h - 1)));
      for (int x = 0; x < w; ++x) {
        const float z = depth.at(x, y);
        if (!Valid(z)) continue;
        const float a = static_cast<float>((x - camera.cx) / camera.fx);
        Eigen::Vector3f q(a * z, b * z, z);
        if (rolling) q -= key_w.cross(q);
        Eigen::Vector3f p = r * q + t;
        if (p.z() < 0.05f) continue;
        if (rolling) {
          // The row that sees the point depends on the row's rotation: a
          // few fixed-point steps (each one shrinks the row error by
          // |omega| readout fy / H, about 0.1 at TUM's fastest rotation).
          const Eigen::Vector3f mid = p;
          float row = camera.fy * p.y() / p.z() + static_cast<float>(camera.cy);
          for (int step = 0; step < 4; ++step) {
            p = mid + (other_omega * (tau_per_row * (row - 0.5f * (h - 1)))).cross(mid);
            const float next = camera.fy * p.y() / p.z() + static_cast<float>(camera.cy);
            const bool settled = std::abs(next - row) < 0.5f;
            row = next;
            if (settled) break;
          }
          if (p.z() < 0.05f) continue;
        }
        const int u = static_cast<int>(std::lround(fx * p.x() / p.z() + cx));
        const int v = static_cast<int>(std::lround(fy * p.y() / p.z() + cy));
        if (u < 0 || v < 0 || u >= ow || v >= oh) continue;
        const float seen = od.at(u, v);
        if (seen <= 0.0f) continue;
        if (seen > p.z() + std::max(options.margin_m, options.margin_rel * p.z())) ++votes[static_cast<size_t>(y) * w + x];
      }
    }
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (votes[static_cast<size_t>(y) * w + x] >= options.votes) mask.at(x, y) = 255;
  if (options.dilate > 0) {
    cv::Mat m(h, w, CV_8UC1, mask.data());
    const int k = 2 * options.dilate * options.downscale + 1;
    cv::dilate(m, m, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k)));
  }
  return mask;
}

SeenThroughQueue::SeenThroughQueue(const Camera& pinhole, const SeenThroughOptions& options)
    : camera_(pinhole), options_(options) {
  options_.Validate();
}

long long SeenThroughQueue::Add(const ImageF& depth, const Rigid3d& cam_from_world, const Eigen::Vector3d& omega) {
  frames_.push_back({MinAround(MinPoolDepth(depth, options_.downscale), options_.edge_blocks), cam_from_world, omega});
  while (static_cast<int>(frames_.size()) > 2 * options_.window + 1) frames_.pop_front();
  return next_frame_++;
}

void SeenThroughQueue::Hold(int id, KeyframeInput input, long long frame) {
  DYPHO_CHECK(frame >= 0 && frame < next_frame_) << "SeenThroughQueue::Hold: frame " << frame << " was not added";
  const Rigid3d pose = input.cam_from_world;
  const Eigen::Vector3d omega = input.angular_velocity;
  held_.push_back({id, frame, std::move(input), pose, omega});
}

std::vector<std::pair<int, KeyframeInput>> SeenThroughQueue::Release(bool all) {
  std::vector<std::pair<int, KeyframeInput>> out;
  const long long last = next_frame_ - 1;
  const long long first_kept = next_frame_ - static_cast<long long>(frames_.size());
  while (!held_.empty() && (all || held_.front().frame + options_.window <= last)) {
    Held item = std::move(held_.front());
    held_.pop_front();
    KeyframeInput& in = item.input;
    if (!in.depth.empty()) {
      // The frames of the window that are still kept, the keyframe's own left out.
      std::vector<long long> window;
      for (long long i = std::max(first_kept, item.frame - options_.window);
           i <= std::min(last, item.frame + options_.window); ++i)
        if (i != item.frame) window.push_back(i);
      std::vector<const DepthAtPose*> others;
      const int n = static_cast<int>(window.size());
      const int take = std::min(n, options_.neighbours);
      for (int k = 0; k < take; ++k) {
        const int pick = take == 1 ? n / 2 : static_cast<int>(std::lround(static_cast<double>(k) * (n - 1) / (take - 1)));
        others.push_back(&frames_[static_cast<size_t>(window[static_cast<size_t>(pick)] - first_kept)]);
      }
      const ImageU8 seen = SeenThroughMask(camera_, in.depth, item.test_pose, others, options_, item.omega);
      if (in.dynamic_mask.empty()) in.dynamic_mask = ImageU8(seen.width(), seen.height(), 1, 0);
      for (int y = 0; y < seen.height(); ++y)
        for (int x = 0; x < seen.width(); ++x)
          if (seen.at(x, y) && !in.dynamic_mask.at(x, y)) {
            in.dynamic_mask.at(x, y) = 255;
            ++masked_pixels_;
          }
    }
    out.emplace_back(item.id, std::move(in));
  }
  return out;
}

bool SeenThroughQueue::SetPose(int id, const Rigid3d& cam_from_world) {
  for (Held& h : held_)
    if (h.id == id) {
      h.input.cam_from_world = cam_from_world;
      return true;
    }
  return false;
}

bool SeenThroughQueue::GetPose(int id, Rigid3d* cam_from_world) const {
  for (const Held& h : held_)
    if (h.id == id) {
      *cam_from_world = h.input.cam_from_world;
      return true;
    }
  return false;
}

}  // namespace dypho
