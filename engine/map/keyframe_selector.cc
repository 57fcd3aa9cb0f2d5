#include "engine/map/keyframe_selector.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "tracker/cv_view.h"

namespace dypho {

void KeyframePolicy::Validate() const {
  DYPHO_CHECK_INPUT(std::isfinite(max_translation) && max_translation > 0)
      << "keyframe policy max_translation must be > 0 m (got " << max_translation << ")";
  DYPHO_CHECK_INPUT(std::isfinite(max_rotation_deg) && max_rotation_deg > 0)
      << "keyframe policy max_rotation_deg must be > 0 (got " << max_rotation_deg << ")";
  DYPHO_CHECK_INPUT(max_frame_gap >= 1) << "keyframe policy max_frame_gap must be >= 1 (got " << max_frame_gap << ")";
  DYPHO_CHECK_INPUT(std::isfinite(min_new_content) && min_new_content >= 0 && min_new_content <= 1)
      << "keyframe policy min_new_content must be in [0, 1] (got " << min_new_content << ")";
  DYPHO_CHECK_INPUT(sample_step_px >= 2 && sample_step_px <= 64)
      << "keyframe policy sample_step_px must be in [2, 64] (got " << sample_step_px << ")";
  DYPHO_CHECK_INPUT(std::isfinite(visibility_tolerance) && visibility_tolerance > 0 && visibility_tolerance < 1)
      << "keyframe policy visibility_tolerance must be in (0, 1) (got " << visibility_tolerance << ")";
  DYPHO_CHECK_INPUT(std::isfinite(tail_new_content) && tail_new_content >= 0 && tail_new_content <= 1)
      << "keyframe policy tail_new_content must be in [0, 1] (got " << tail_new_content << ")";
  DYPHO_CHECK_INPUT(std::isfinite(sharper_ratio) && (sharper_ratio == 0 || sharper_ratio >= 1))
      << "keyframe policy sharper_ratio must be 0 (off) or >= 1 (got " << sharper_ratio << ")";
  DYPHO_CHECK_INPUT(sharpness_window >= 1 && sharpness_window <= kMaxSharpnessWindow)
      << "keyframe policy sharpness_window must be in [1, " << kMaxSharpnessWindow << "] (got " << sharpness_window
      << ")";
}

namespace {

// A keyframe as the content test sees it: its pose and a coarse depth map of
// the ideal pinhole camera (one cell per sample step).
struct KeyframeRecord {
  Rigid3d cam_from_world;
  cv::Mat coarse;  // CV_32F, 0 = no depth
  double sharpness = 0.0;
};

}  // namespace

struct KeyframeSelector::Impl {
  KeyframePolicy policy;
  Camera camera;
  int cols = 0, rows = 0;           // coarse grid
  std::vector<cv::Point> samples;   // sampled (distorted) pixels
  std::vector<Eigen::Vector2d> rays;  // their ideal rays (x/z, y/z)
  std::vector<KeyframeRecord> keyframes;
  long frame = 0;                   // frames offered
  long last_keyframe_frame = -1;
  std::optional<Rigid3d> last_keyframe_pose;
  // The open sharpness window.
  bool window_open = false;
  int window_frames = 0;
  double best_sharpness = -1.0;
  long best_frame = -1;
  Rigid3d best_pose;
  std::vector<Eigen::Vector3d> best_points;  // camera-frame points of the best candidate
  // The tail candidate (no window open): the newest frame since the last
  // keyframe with at least tail_new_content, kept for the end of the
  // sequence (best_* hold it; best_frame >= 0).
  bool tail = false;

  bool UsesSharpness() const { return policy.sharpness_window > 1 || policy.sharper_ratio > 0; }

  void Init() {
    const int step = policy.sample_step_px;
    cols = (camera.width + step - 1) / step;
    rows = (camera.height + step - 1) / step;
    for (int v = step / 2; v < camera.height; v += step) {
      for (int u = step / 2; u < camera.width; u += step) {
        const Eigen::Vector2d ideal = camera.HasDistortion() ? camera.Undistort({u, v}) : Eigen::Vector2d(u, v);
        samples.emplace_back(u, v);
        rays.emplace_back((ideal.x() - camera.cx) / camera.fx, (ideal.y() - camera.cy) / camera.fy);
      }
    }
  }

  bool Cell(const Eigen::Vector3d& p, int* cx, int* cy) const {
    if (p.z() <= 0.05) return false;
    const double u = camera.fx * p.x() / p.z() + camera.cx, v = camera.fy * p.y() / p.z() + camera.cy;
    if (!(u >= -0.5 && v >= -0.5 && u < camera.width - 0.5 && v < camera.height - 0.5)) return false;
    *cx = std::clamp(static_cast<int>((u + 0.5) / policy.sample_step_px), 0, cols - 1);
    *cy = std::clamp(static_cast<int>((v + 0.5) / policy.sample_step_px), 0, rows - 1);
    return true;
  }

  bool Explained(const KeyframeRecord& k, const Eigen::Vector3d& world) const {
    const Eigen::Vector3d p = k.cam_from_world * world;
    int cx, cy;
    if (!Cell(p, &cx, &cy)) return false;
    const double tol = policy.visibility_tolerance * p.z() + 0.02;
    for (int y = std::max(0, cy - 1); y <= std::min(rows - 1, cy + 1); ++y) {
      for (int x = std::max(0, cx - 1); x <= std::min(cols - 1, cx + 1); ++x) {
        const float d = k.coarse.at<float>(y, x);
        if (d > 0 && std::abs(d - p.z()) < tol) return true;
      }
    }
    return false;
  }

  // Whether a world point falls inside a keyframe's image (in front of it).
  bool InView(const KeyframeRecord& k, const Eigen::Vector3d& world) const {
    int cx, cy;
    return Cell(k.cam_from_world * world, &cx, &cy);
  }

  static double MedianDepth(const std::vector<Eigen::Vector3d>& points) {
    std::vector<double> z;
    z.reserve(points.size());
    for (const Eigen::Vector3d& p : points) z.push_back(p.z());
    std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
    return z[z.size() / 2];
  }

  // The offered frame becomes the kept candidate.
  void Keep(long frame, const Rigid3d& cam_from_world, double sharpness, std::vector<Eigen::Vector3d> points) {
    best_sharpness = sharpness;
    best_frame = frame;
    best_pose = cam_from_world;
    best_points = std::move(points);
  }

  void Commit() {
    KeyframeRecord k;
    k.cam_from_world = best_pose;
    k.sharpness = best_sharpness;
    k.coarse = cv::Mat::zeros(rows, cols, CV_32F);
    for (const Eigen::Vector3d& p : best_points) {
      int cx, cy;
      if (!Cell(p, &cx, &cy)) continue;
      float& d = k.coarse.at<float>(cy, cx);
      if (d == 0 || p.z() < d) d = static_cast<float>(p.z());
    }
    keyframes.push_back(std::move(k));
    last_keyframe_pose = best_pose;
    last_keyframe_frame = best_frame;
    window_open = false;
    tail = false;
    best_frame = -1;
    best_points.clear();
  }
};

KeyframeSelector::KeyframeSelector(const KeyframePolicy& policy, const Camera& camera) : impl_(new Impl) {
  policy.Validate();
  camera.Validate("keyframe selector camera");
  impl_->policy = policy;
  impl_->camera = camera;
  impl_->Init();
}

KeyframeSelector::~KeyframeSelector() = default;
KeyframeSelector::KeyframeSelector(KeyframeSelector&&) noexcept = default;
KeyframeSelector& KeyframeSelector::operator=(KeyframeSelector&&) noexcept = default;

KeyframeDecision KeyframeSelector::Offer(const Rigid3d& cam_from_world, const ImageF& depth, const ImageU8& rgb,
                                         const ImageU8& dynamic_mask) {
  Impl& m = *impl_;
  KeyframeDecision d;
  const long frame = m.frame++;
  if (depth.empty()) return d;
  DYPHO_CHECK_INPUT(depth.width() == m.camera.width && depth.height() == m.camera.height)
      << "keyframe selector: depth is " << depth.width() << "x" << depth.height() << ", the camera "
      << m.camera.width << "x" << m.camera.height;
  const bool masked = !dynamic_mask.empty();
  std::vector<Eigen::Vector3d> points;  // camera frame
  std::vector<size_t> depthless;        // static samples without depth
  points.reserve(m.samples.size());
  for (size_t i = 0; i < m.samples.size(); ++i) {
    const cv::Point& s = m.samples[i];
    if (masked && dynamic_mask.data()[static_cast<size_t>(s.y) * dynamic_mask.width() + s.x]) continue;
    const float z = depth.data()[static_cast<size_t>(s.y) * depth.width() + s.x];
    if (!(std::isfinite(z) && z > 0)) {
      depthless.push_back(i);
      continue;
    }
    points.emplace_back(m.rays[i].x() * z, m.rays[i].y() * z, z);
  }
  if (!m.window_open) {
    bool due = m.keyframes.empty() || frame - m.last_keyframe_frame >= m.policy.max_frame_gap;
    if (!due && m.last_keyframe_pose) {
      const Rigid3d rel = cam_from_world * m.last_keyframe_pose->Inverse();
      const double angle = Eigen::AngleAxisd(rel.rotation).angle() * 180.0 / M_PI;
      const Eigen::Vector3d moved = cam_from_world.Inverse().translation - m.last_keyframe_pose->Inverse().translation;
      due = moved.norm() > m.policy.max_translation || angle > m.policy.max_rotation_deg;
    }
    d.sharpness = m.UsesSharpness() ? ImageSharpness(rgb, dynamic_mask) : 0.0;
    const bool content = m.policy.min_new_content > 0, sharper = m.policy.sharper_ratio > 0;
    if ((content || sharper) && !m.keyframes.empty() && !points.empty()) {
      const Rigid3d world_from_cam = cam_from_world.Inverse();
      int unexplained = 0;
      std::vector<double> seen;  // per point: the sharpest keyframe that explains it (0 = none)
      seen.reserve(points.size());
      for (const Eigen::Vector3d& p : points) {
        const Eigen::Vector3d world = world_from_cam * p;
        double best = -1.0;
        for (auto k = m.keyframes.rbegin(); k != m.keyframes.rend(); ++k) {
          if ((sharper || best < 0) && k->sharpness > best && m.Explained(*k, world)) best = k->sharpness;
          if (!sharper && best >= 0) break;
        }
        unexplained += best < 0;
        seen.push_back(std::max(0.0, best));
      }
      // Samples without depth (beyond the sensor's range, dark or shiny
      // surfaces) are new content when no keyframe looked that way: each is
      // put at the frame's median depth and is unexplained when that point
      // falls outside every keyframe's image.
      const double proxy = m.MedianDepth(points);
      for (const size_t i : depthless) {
        const Eigen::Vector3d world = world_from_cam * (proxy * Eigen::Vector3d(m.rays[i].x(), m.rays[i].y(), 1.0));
        bool in_view = false;
        for (auto k = m.keyframes.rbegin(); k != m.keyframes.rend() && !in_view; ++k) in_view = m.InView(*k, world);
        unexplained += !in_view;
      }
      d.new_content = static_cast<double>(unexplained) / (points.size() + depthless.size());
      if (content) due = due || d.new_content >= m.policy.min_new_content;
      if (sharper) {
        std::nth_element(seen.begin(), seen.begin() + seen.size() / 2, seen.end());
        d.seen_sharpness = seen[seen.size() / 2];
        due = due || d.sharpness >= m.policy.sharper_ratio * d.seen_sharpness;
      }
    } else if (m.keyframes.empty()) {
      d.new_content = 1.0;
    }
    if (points.empty()) return d;
    if (!due) {
      // Not due: perhaps the tail candidate. A newer frame replaces it
      // unless the kept one is sharper and at most a window old.
      const bool tail = m.policy.tail_new_content > 0 && !m.keyframes.empty() &&
                        d.new_content >= m.policy.tail_new_content;
      if (tail && (!m.tail || frame - m.best_frame >= m.policy.sharpness_window || d.sharpness >= m.best_sharpness)) {
        d.keep = true;
        m.tail = true;
        m.Keep(frame, cam_from_world, d.sharpness, std::move(points));
      }
      return d;
    }
    m.tail = false;
    m.window_open = true;
    m.window_frames = 0;
    m.best_sharpness = -1.0;
    m.best_frame = -1;
  }
  if (d.sharpness == 0.0 && m.UsesSharpness()) d.sharpness = ImageSharpness(rgb, dynamic_mask);
  ++m.window_frames;
  if (!points.empty() && d.sharpness > m.best_sharpness) {
    d.keep = true;
    m.Keep(frame, cam_from_world, d.sharpness, std::move(points));
  }
  if (m.window_frames >= m.policy.sharpness_window && m.best_frame >= 0) {
    d.emit = true;
    m.Commit();
  }
  return d;
}

bool KeyframeSelector::pending() const { return (impl_->window_open || impl_->tail) && impl_->best_frame >= 0; }

bool KeyframeSelector::Flush() {
  if (!pending()) return false;
  impl_->Commit();
  return true;
}

int KeyframeSelector::num_keyframes() const { return static_cast<int>(impl_->keyframes.size()); }

void KeyframeSelector::Reset() {
  const KeyframePolicy policy = impl_->policy;
  const Camera camera = impl_->camera;
  impl_.reset(new Impl);
  impl_->policy = policy;
  impl_->camera = camera;
  impl_->Init();
}

}  // namespace dypho
