#include "masking/flow_motion.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <sstream>
#include <vector>

#include "common/check.h"
#include "common/files.h"
#include "masking/mat_checks.h"
#include "masking/pixel_rays.h"

namespace dypho {
namespace {

// An odd kernel size for `px` image pixels at `scale`; 0 = none.
int ScaledKernel(int px, double scale) {
  if (px <= 1) return 0;
  const int k = static_cast<int>(std::lround(px * scale));
  return k <= 1 ? 0 : (k | 1);
}

cv::Mat Ellipse(int size) { return cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(size, size)); }

void ToRvecTvec(const Rigid3d& t, cv::Mat* rvec, cv::Mat* tvec) {
  const Eigen::Matrix3d r = t.rotation.toRotationMatrix();
  cv::Matx33d rm;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) rm(i, j) = r(i, j);
  cv::Rodrigues(rm, *rvec);
  *tvec = (cv::Mat_<double>(3, 1) << t.translation.x(), t.translation.y(), t.translation.z());
}

Rigid3d FromRvecTvec(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Matx33d rm;
  cv::Rodrigues(rvec, rm);
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = rm(i, j);
  return Rigid3d(Eigen::Quaterniond(r), Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
}

// Indices of the samples the pose reprojects within `threshold` [working px].
std::vector<int> Inliers(const std::vector<cv::Point3f>& object, const std::vector<cv::Point2f>& image,
                         const cv::Mat& rvec, const cv::Mat& tvec, const cv::Mat& k, const cv::Mat& dist,
                         double threshold) {
  std::vector<cv::Point2f> projected;
  cv::projectPoints(object, rvec, tvec, k, dist, projected);
  std::vector<int> inliers;
  const double t2 = threshold * threshold;
  for (size_t i = 0; i < image.size(); ++i) {
    const cv::Point2f d = projected[i] - image[i];
    if (d.dot(d) <= t2) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

template <typename T>
std::vector<T> Select(const std::vector<T>& v, const std::vector<int>& indices) {
  std::vector<T> out;
  out.reserve(indices.size());
  for (int i : indices) out.push_back(v[i]);
  return out;
}

}  // namespace

bool FlowMotionOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(scale > 0 && scale <= 1))
    msg << "scale must be in (0, 1] (got " << scale << ")";
  else if (dis_preset < 0 || dis_preset > 2)
    msg << "dis_preset must be 0, 1 or 2 (got " << dis_preset << ")";
  else if (!(residual_threshold_px > 0))
    msg << "residual_threshold_px must be > 0 (got " << residual_threshold_px << ")";
  else if (!(noise_factor >= 0))
    msg << "noise_factor must be >= 0 (got " << noise_factor << ")";
  else if (!(relative_threshold >= 0))
    msg << "relative_threshold must be >= 0 (got " << relative_threshold << ")";
  else if (!(depth_noise_abs >= 0))
    msg << "depth_noise_abs must be >= 0 (got " << depth_noise_abs << ")";
  else if (!(depth_noise_rel >= 0))
    msg << "depth_noise_rel must be >= 0 (got " << depth_noise_rel << ")";
  else if (!(max_depth > 0))
    msg << "max_depth must be > 0 (got " << max_depth << ")";
  else if (!(occlusion_margin > 0))
    msg << "occlusion_margin must be > 0 (got " << occlusion_margin << ")";
  else if (open_px < 0 || open_px > 51)
    msg << "open_px must be in 0..51 (got " << open_px << ")";
  else if (close_px < 0 || close_px > 51)
    msg << "close_px must be in 0..51 (got " << close_px << ")";
  else if (min_region_px < 0)
    msg << "min_region_px must be >= 0 (got " << min_region_px << ")";
  else if (pose_grid_px < 2 || pose_grid_px > 64)
    msg << "pose_grid_px must be in 2..64 (got " << pose_grid_px << ")";
  else if (!(pose_inlier_px > 0))
    msg << "pose_inlier_px must be > 0 (got " << pose_inlier_px << ")";
  else if (pose_min_inliers < 6)
    msg << "pose_min_inliers must be >= 6 (got " << pose_min_inliers << ")";
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

struct FlowMotion::Impl {
  FlowMotionOptions options;
  Camera camera;                    // full size
  Camera working_camera;            // at options.scale
  std::unique_ptr<PixelRays> rays;  // working camera
  cv::Ptr<cv::DISOpticalFlow> dis;
  cv::Mat k, dist;  // working camera matrix and distortion for PnP

  // Pose from the flow (see the header); nullopt when it fails.
  std::optional<Rigid3d> EstimatePose(const BackwardFlow& flow, const cv::Mat& depth_w, const cv::Mat& exclude,
                                      const std::optional<Rigid3d>& guess, FlowMotionResult* result) const;
};

FlowMotion::FlowMotion(const FlowMotionOptions& options, const Camera& camera) : impl_(std::make_unique<Impl>()) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "FlowMotionOptions." << error;
  camera.Validate("FlowMotion");
  KeepFreedMemory();  // per-frame buffers: reuse freed memory (see common/files.h)
  impl_->options = options;
  impl_->camera = camera;
  impl_->working_camera = options.scale == 1.0 ? camera : camera.Scaled(options.scale);
  impl_->rays = std::make_unique<PixelRays>(impl_->working_camera);
  impl_->dis = cv::DISOpticalFlow::create(options.dis_preset);
  const Camera& c = impl_->working_camera;
  impl_->k = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  impl_->dist = cv::Mat(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) impl_->dist.at<double>(i) = c.distortion[i];
}

FlowMotion::~FlowMotion() = default;

const FlowMotionOptions& FlowMotion::options() const { return impl_->options; }

cv::Size FlowMotion::working_size() const { return impl_->rays->size(); }

BackwardFlow FlowMotion::ComputeFlow(const cv::Mat& gray, const cv::Mat& prev_gray) {
  const cv::Size size(impl_->camera.width, impl_->camera.height);
  CheckMat(gray, CV_8UC1, size, "gray");
  CheckMat(prev_gray, CV_8UC1, size, "prev_gray");
  BackwardFlow flow;
  flow.scale = impl_->options.scale;
  flow.image_size = size;
  if (flow.scale == 1.0) {
    impl_->dis->calc(gray, prev_gray, flow.field);
  } else {
    cv::Mat a, b;
    cv::resize(gray, a, working_size(), 0, 0, cv::INTER_AREA);
    cv::resize(prev_gray, b, working_size(), 0, 0, cv::INTER_AREA);
    impl_->dis->calc(a, b, flow.field);
  }
  return flow;
}

std::optional<Rigid3d> FlowMotion::Impl::EstimatePose(const BackwardFlow& flow, const cv::Mat& depth_w,
                                                      const cv::Mat& exclude, const std::optional<Rigid3d>& guess,
                                                      FlowMotionResult* result) const {
  const FlowMotionOptions& o = options;
  const cv::Size ws = rays->size();
  const int step = std::max(1, static_cast<int>(std::lround(o.pose_grid_px * o.scale)));
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  for (int v = step / 2; v < ws.height; v += step) {
    for (int u = step / 2; u < ws.width; u += step) {
      if (!exclude.empty()) {
        const int fu = std::min(exclude.cols - 1, static_cast<int>((u + 0.5) / o.scale));
        const int fv = std::min(exclude.rows - 1, static_cast<int>((v + 0.5) / o.scale));
        if (exclude.at<uint8_t>(fv, fu)) continue;
      }
      const float z = depth_w.at<float>(v, u);
      if (!(z > 0.0f && z <= o.max_depth)) continue;
      const cv::Vec2f f = flow.field.at<cv::Vec2f>(v, u);
      const float xp = u + f[0], yp = v + f[1];
      if (!(xp >= 0 && yp >= 0 && xp <= ws.width - 1 && yp <= ws.height - 1)) continue;
      const cv::Vec2f& ray = rays->Ray(u, v);
      object.emplace_back(z * ray[0], z * ray[1], z);
      image.emplace_back(xp, yp);
    }
  }
  result->pose_samples = static_cast<int>(object.size());
  if (static_cast<int>(object.size()) < o.pose_min_inliers) return std::nullopt;
  const double threshold = o.pose_inlier_px * o.scale;
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  if (guess) {
    ToRvecTvec(guess->Inverse(), &rvec, &tvec);  // prev_from_cam
    inliers = Inliers(object, image, rvec, tvec, k, dist, threshold);
  }
  if (inliers.size() < 0.7 * object.size()) {
    // The guess (if any) explains too little: RANSAC from scratch.
    cv::Mat r, t;
    std::vector<int> ransac_inliers;
    const bool ok = cv::solvePnPRansac(object, image, k, dist, r, t, false, 200, static_cast<float>(threshold), 0.999,
                                       ransac_inliers, cv::SOLVEPNP_AP3P);
    if (ok && ransac_inliers.size() > inliers.size()) {
      rvec = r;
      tvec = t;
      inliers = ransac_inliers;
    }
  }
  if (static_cast<int>(inliers.size()) < o.pose_min_inliers) return std::nullopt;
  // Levenberg-Marquardt on the inliers, then the final inlier count.
  cv::solvePnPRefineLM(Select(object, inliers), Select(image, inliers), k, dist, rvec, tvec);
  inliers = Inliers(object, image, rvec, tvec, k, dist, threshold);
  result->pose_inliers = static_cast<int>(inliers.size());
  if (static_cast<int>(inliers.size()) < o.pose_min_inliers) return std::nullopt;
  return FromRvecTvec(rvec, tvec).Inverse();
}

FlowMotionResult FlowMotion::Detect(const BackwardFlow& flow, const cv::Mat& depth,
                                    const std::optional<Rigid3d>& cam_from_prev, const cv::Mat& exclude,
                                    const cv::Mat& prev_depth) {
  const FlowMotionOptions& o = impl_->options;
  const cv::Size size(impl_->camera.width, impl_->camera.height);
  const cv::Size ws = working_size();
  CheckMat(depth, CV_32FC1, size, "depth");
  CheckOptionalMat(exclude, CV_8UC1, size, "exclude");
  CheckOptionalMat(prev_depth, CV_32FC1, size, "prev_depth");
  DYPHO_CHECK_INPUT(!flow.empty() && flow.field.type() == CV_32FC2 && flow.field.size() == ws &&
                    flow.image_size == size)
      << "flow does not come from this FlowMotion (working size " << SizeText(ws) << ")";

  FlowMotionResult result;
  result.mask = cv::Mat(size, CV_8UC1, cv::Scalar(0));
  result.residual_ratio = cv::Mat(ws, CV_32FC1, cv::Scalar(0));
  cv::Mat depth_w;
  cv::Mat prev_depth_w = prev_depth;
  if (ws == size) {
    depth_w = depth;
  } else {
    cv::resize(depth, depth_w, ws, 0, 0, cv::INTER_NEAREST);
    if (!prev_depth.empty()) cv::resize(prev_depth, prev_depth_w, ws, 0, 0, cv::INTER_NEAREST);
  }

  std::optional<Rigid3d> pose = cam_from_prev;
  if (o.estimate_pose) {
    const std::optional<Rigid3d> estimate = impl_->EstimatePose(flow, depth_w, exclude, cam_from_prev, &result);
    if (estimate) {
      pose = estimate;
      result.pose_estimated = true;
    }
  }
  if (!pose) return result;
  result.has_pose = true;
  result.cam_from_prev = *pose;

  // Residual against the rigid flow, per pixel at the working scale.
  const RigidF prev_from_cam(pose->Inverse());
  const PixelRays& rays = *impl_->rays;
  const float base = static_cast<float>(o.residual_threshold_px * o.scale);
  const float noise_factor = static_cast<float>(o.noise_factor);
  const float relative = static_cast<float>(o.relative_threshold);
  const float noise_abs = static_cast<float>(o.depth_noise_abs), noise_rel = static_cast<float>(o.depth_noise_rel);
  const float max_depth = static_cast<float>(o.max_depth);
  const float occlusion_margin = static_cast<float>(o.occlusion_margin);
  const bool occlusion_test = !prev_depth_w.empty();
  const float w_max = ws.width - 1.0f, h_max = ws.height - 1.0f;
  cv::Mat moving(ws, CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < ws.height; ++v) {
    const float* zrow = depth_w.ptr<float>(v);
    const cv::Vec2f* frow = flow.field.ptr<cv::Vec2f>(v);
    const cv::Vec2f* rrow = rays.rays().ptr<cv::Vec2f>(v);
    float* out = result.residual_ratio.ptr<float>(v);
    uint8_t* mrow = moving.ptr<uint8_t>(v);
    for (int u = 0; u < ws.width; ++u) {
      const float z = zrow[u];
      if (!(z > 0.0f && z <= max_depth)) continue;
      const float fx = u + frow[u][0], fy = v + frow[u][1];
      if (!(fx >= 0.0f && fy >= 0.0f && fx <= w_max && fy <= h_max)) continue;
      const float rx = rrow[u][0], ry = rrow[u][1];
      float px, py, pz;
      prev_from_cam.Apply(z * rx, z * ry, z, &px, &py, &pz);
      float ux, uy;
      if (!rays.Project(px, py, pz, &ux, &uy)) continue;
      if (!(ux >= 0.0f && uy >= 0.0f && ux <= w_max && uy <= h_max)) continue;
      const float sigma = noise_abs + noise_rel * z * z;
      if (occlusion_test) {
        const float zp = prev_depth_w.at<float>(static_cast<int>(uy + 0.5f), static_cast<int>(ux + 0.5f));
        const float sigma_p = noise_abs + noise_rel * pz * pz;
        if (zp > 0.0f && zp < pz - occlusion_margin - 3.0f * sigma_p) {
          ++result.occluded;
          continue;
        }
      }
      // The same pixel's point one depth sigma farther: X' = X + sigma R ray.
      float qx, qy, qz;
      prev_from_cam.Apply((z + sigma) * rx, (z + sigma) * ry, z + sigma, &qx, &qy, &qz);
      float sx = ux, sy = uy;
      rays.Project(qx, qy, qz, &sx, &sy);
      const float shift = std::sqrt((sx - ux) * (sx - ux) + (sy - uy) * (sy - uy));
      const float rigid = std::sqrt((ux - u) * (ux - u) + (uy - v) * (uy - v));
      const float threshold = base + noise_factor * shift + relative * rigid;
      const float residual = std::sqrt((fx - ux) * (fx - ux) + (fy - uy) * (fy - uy));
      out[u] = residual / threshold;
      if (residual > threshold) mrow[u] = 255;
    }
  }

  // Clean-up at the working scale, then back to the image size.
  const int open_k = ScaledKernel(o.open_px, o.scale), close_k = ScaledKernel(o.close_px, o.scale);
  if (open_k) cv::morphologyEx(moving, moving, cv::MORPH_OPEN, Ellipse(open_k));
  if (close_k) cv::morphologyEx(moving, moving, cv::MORPH_CLOSE, Ellipse(close_k));
  RemoveSmallRegions(moving, static_cast<int>(std::lround(o.min_region_px * o.scale * o.scale)));
  if (ws == size) {
    result.mask = moving;
  } else {
    cv::resize(moving, result.mask, size, 0, 0, cv::INTER_LINEAR);
    cv::threshold(result.mask, result.mask, 127, 255, cv::THRESH_BINARY);
  }
  return result;
}

cv::Mat WarpMaskByFlow(const cv::Mat& prev_mask, const BackwardFlow& flow) {
  CheckMat(prev_mask, CV_8UC1, flow.image_size, "prev_mask");
  DYPHO_CHECK_INPUT(!flow.empty() && flow.field.type() == CV_32FC2) << "flow is empty";
  cv::Mat full;
  if (flow.field.size() == flow.image_size) {
    full = flow.field.clone();
  } else {
    cv::resize(flow.field, full, flow.image_size, 0, 0, cv::INTER_LINEAR);
    full *= 1.0 / flow.scale;
  }
  for (int v = 0; v < full.rows; ++v) {
    cv::Vec2f* row = full.ptr<cv::Vec2f>(v);
    for (int u = 0; u < full.cols; ++u) row[u] += cv::Vec2f(static_cast<float>(u), static_cast<float>(v));
  }
  cv::Mat warped;
  cv::remap(prev_mask, warped, full, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::threshold(warped, warped, 127, 255, cv::THRESH_BINARY);
  return warped;
}

void RemoveSmallRegions(cv::Mat& full_mask, int min_area) {
  if (min_area <= 1 || full_mask.empty()) return;
  // Only the bounding box of the nonzero pixels needs labelling.
  const cv::Rect box = cv::boundingRect(full_mask);
  if (box.empty()) return;
  cv::Mat mask = full_mask(box);
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<uint8_t> keep(n, 0);
  bool any_dropped = false;
  for (int i = 1; i < n; ++i) {
    keep[i] = stats.at<int>(i, cv::CC_STAT_AREA) >= min_area;
    any_dropped |= !keep[i];
  }
  if (!any_dropped) return;
  for (int v = 0; v < mask.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    uint8_t* m = mask.ptr<uint8_t>(v);
    for (int u = 0; u < mask.cols; ++u) m[u] = keep[l[u]] ? 255 : 0;
  }
}

}  // namespace dypho
