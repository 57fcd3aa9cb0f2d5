#include "masking/background_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/check.h"
#include "common/files.h"
#include "masking/flow_motion.h"
#include "masking/mat_checks.h"

namespace dypho {
namespace {

inline bool Valid(float z, float max_depth) { return z > 0.0f && z <= max_depth; }

}  // namespace

bool BackgroundOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(prior_weight > 0))
    msg << "prior_weight must be > 0 (got " << prior_weight << ")";
  else if (!(observation_weight > 0))
    msg << "observation_weight must be > 0 (got " << observation_weight << ")";
  else if (!(tolerance_abs > 0))
    msg << "tolerance_abs must be > 0 (got " << tolerance_abs << ")";
  else if (!(tolerance_rel >= 0))
    msg << "tolerance_rel must be >= 0 (got " << tolerance_rel << ")";
  else if (!(front_factor >= 1))
    msg << "front_factor must be >= 1 (got " << front_factor << ")";
  else if (window_radius_px < 1 || window_radius_px > 15)
    msg << "window_radius_px must be in 1..15 (got " << window_radius_px << ")";
  else if (alignment_px < 0 || alignment_px > 15)
    msg << "alignment_px must be in 0..15 (got " << alignment_px << ")";
  else if (min_support < 1 || min_support > 255)
    msg << "min_support must be in 1..255 (got " << min_support << ")";
  else if (!(min_valid_fraction > 0 && min_valid_fraction <= 1))
    msg << "min_valid_fraction must be in (0, 1] (got " << min_valid_fraction << ")";
  else if (!(static_fraction > 0 && static_fraction <= 1))
    msg << "static_fraction must be in (0, 1] (got " << static_fraction << ")";
  else if (!(dynamic_fraction > 0 && dynamic_fraction <= 1))
    msg << "dynamic_fraction must be in (0, 1] (got " << dynamic_fraction << ")";
  else if (min_region_px < 0)
    msg << "min_region_px must be >= 0 (got " << min_region_px << ")";
  else if (!(max_depth > 0))
    msg << "max_depth must be > 0 (got " << max_depth << ")";
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

BackgroundRefinement RefineMask(const cv::Mat& depth, const cv::Mat& raw_mask, const cv::Mat& background,
                                const cv::Mat& support, const BackgroundOptions& o) {
  const cv::Size size = depth.size();
  CheckMat(depth, CV_32FC1, size, "depth");
  CheckMat(raw_mask, CV_8UC1, size, "raw_mask");
  CheckMat(background, CV_32FC1, size, "background");
  CheckMat(support, CV_8UC1, size, "support");
  std::string error;
  DYPHO_CHECK_INPUT(o.IsValid(&error)) << "RefineMask: BackgroundOptions." << error;
  const float max_depth = static_cast<float>(o.max_depth);
  const float tol_abs = static_cast<float>(o.tolerance_abs), tol_rel = static_cast<float>(o.tolerance_rel);
  const float front_factor = static_cast<float>(o.front_factor);
  auto tol = [&](float z) { return tol_abs + tol_rel * z * z; };
  BackgroundRefinement out;
  // 3. Nearest and farthest background within alignment_px, then the
  // per-pixel indicators (valid, agree, front) as 0/1.
  cv::Mat near_bg, far_bg;  // own buffers: erode/dilate must not write into B
  if (o.alignment_px == 0) {
    near_bg = far_bg = background;
  } else {
    const cv::Mat disc =
        cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * o.alignment_px + 1, 2 * o.alignment_px + 1));
    cv::Mat inf_for_empty = background.clone();
    inf_for_empty.setTo(std::numeric_limits<float>::infinity(), background <= 0.0f);
    cv::erode(inf_for_empty, near_bg, disc);
    cv::dilate(background, far_bg, disc);
  }
  cv::Mat indicators(size, CV_8UC3);
  for (int v = 0; v < size.height; ++v) {
    const float* d = depth.ptr<float>(v);
    const float* b = background.ptr<float>(v);
    const float* lo = near_bg.ptr<float>(v);
    const float* hi = far_bg.ptr<float>(v);
    const uint8_t* sp = support.ptr<uint8_t>(v);
    cv::Vec3b* ind = indicators.ptr<cv::Vec3b>(v);
    for (int u = 0; u < size.width; ++u) {
      const float z = d[u];
      const bool both = Valid(z, max_depth) && b[u] > 0.0f && std::isfinite(lo[u]);
      if (!both) {
        ind[u] = cv::Vec3b(0, 0, 0);
        continue;
      }
      const float t_lo = tol(lo[u]);
      const bool agree = sp[u] >= o.min_support && z >= lo[u] - t_lo && z <= hi[u] + tol(hi[u]);
      ind[u] = cv::Vec3b(1, agree, z < lo[u] - front_factor * t_lo);
    }
  }

  // 3. Neighbourhood counts.
  const int k = 2 * o.window_radius_px + 1;
  const cv::Size window(k, k);
  cv::Mat counts;  // CV_16UC3: (n_valid, n_agree, n_front) over the window
  cv::boxFilter(indicators, counts, CV_16U, window, cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  const float min_valid = static_cast<float>(o.min_valid_fraction * k * k);
  const float static_fraction = static_cast<float>(o.static_fraction);
  const float dynamic_fraction = static_cast<float>(o.dynamic_fraction);
  out.refined_mask = cv::Mat(size, CV_8UC1, cv::Scalar(0));
  cv::Mat added(size, CV_8UC1, cv::Scalar(0));
  long decided = 0;
  for (int v = 0; v < size.height; ++v) {
    const uint8_t* m = raw_mask.ptr<uint8_t>(v);
    const cv::Vec<uint16_t, 3>* c = counts.ptr<cv::Vec<uint16_t, 3>>(v);
    uint8_t* rm = out.refined_mask.ptr<uint8_t>(v);
    uint8_t* ad = added.ptr<uint8_t>(v);
    for (int u = 0; u < size.width; ++u) {
      const bool raw = m[u] != 0;
      rm[u] = raw ? 255 : 0;
      const float n_valid = c[u][0];
      if (n_valid < min_valid - 0.5f) continue;
      ++decided;
      if (c[u][2] >= dynamic_fraction * n_valid) {
        if (!raw && o.add_dynamic) ad[u] = 255;
      } else if (raw && o.remove_static && c[u][1] >= static_fraction * n_valid) {
        rm[u] = 0;
        ++out.removed_pixels;
      }
    }
  }
  if (o.added_open_px > 1) {
    const cv::Rect box = cv::boundingRect(added);
    if (!box.empty()) {
      const int k = o.added_open_px | 1;
      cv::Mat roi = added(box);
      cv::morphologyEx(roi, roi, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k)));
    }
  }
  RemoveSmallRegions(added, o.min_region_px);
  out.added_pixels = cv::countNonZero(added);
  out.refined_mask |= added;
  out.decided_fraction = static_cast<double>(decided) / size.area();
  return out;
}

BackgroundModel::BackgroundModel(const BackgroundOptions& options, const Camera& camera)
    : options_(options), rays_(camera) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "BackgroundOptions." << error;
  // Per-frame buffers of about a megabyte: reuse freed memory instead of
  // touching fresh pages every frame (see common/files.h).
  KeepFreedMemory();
}

cv::Mat BackgroundModel::WarpDepth(const cv::Mat& depth, const Rigid3d& target_from_source) const {
  return Warp(depth, cv::Mat(), target_from_source, nullptr);
}

cv::Mat BackgroundModel::Warp(const cv::Mat& depth, const cv::Mat& values, const Rigid3d& target_from_source,
                              cv::Mat* warped_values) const {
  const cv::Size size = rays_.size();
  CheckMat(depth, CV_32FC1, size, "depth");
  const bool carry = !values.empty() && warped_values != nullptr;
  const float max_depth = static_cast<float>(options_.max_depth);
  constexpr float kEmpty = 0.0f;
  cv::Mat warped(size, CV_32FC1, cv::Scalar(kEmpty));
  cv::Mat carried(carry ? size : cv::Size(), CV_8UC1, cv::Scalar(0));
  uint8_t* carried_pixels = carry ? carried.ptr<uint8_t>() : nullptr;
  const RigidF t(target_from_source);
  float* out_pixels = warped.ptr<float>();
  const float u_end = size.width - 0.5f, v_end = size.height - 0.5f;
  for (int v = 0; v < size.height; ++v) {
    const float* zrow = depth.ptr<float>(v);
    const cv::Vec2f* rrow = rays_.rays().ptr<cv::Vec2f>(v);
    for (int u = 0; u < size.width; ++u) {
      const float z = zrow[u];
      if (!Valid(z, max_depth)) continue;
      float x, y, zt, pu, pv;
      t.Apply(z * rrow[u][0], z * rrow[u][1], z, &x, &y, &zt);
      if (!rays_.Project(x, y, zt, &pu, &pv)) continue;
      if (!(pu >= -0.5f && pv >= -0.5f && pu < u_end && pv < v_end)) continue;
      const int index = static_cast<int>(pv + 0.5f) * size.width + static_cast<int>(pu + 0.5f);
      float& w = out_pixels[index];
      if (w == kEmpty || zt < w) {
        w = zt;
        if (carry) carried_pixels[index] = values.at<uint8_t>(v, u);
      }
    }
  }
  // Cracks: an empty pixel between two filled ones (left-right, up-down or
  // diagonally) gets the mean of its filled 8-neighbours (and the least of
  // their carried values).
  cv::Mat out = warped.clone();
  if (carry) *warped_values = carried.clone();
  for (int v = 1; v + 1 < size.height; ++v) {
    const float* up = warped.ptr<float>(v - 1);
    const float* row = warped.ptr<float>(v);
    const float* down = warped.ptr<float>(v + 1);
    float* o = out.ptr<float>(v);
    for (int u = 1; u + 1 < size.width; ++u) {
      if (row[u] != kEmpty) continue;
      const float n[8] = {row[u - 1], row[u + 1], up[u], down[u], up[u - 1], down[u + 1], up[u + 1], down[u - 1]};
      bool between = false;
      for (int k = 0; k < 8; k += 2) between |= n[k] != kEmpty && n[k + 1] != kEmpty;
      if (!between) continue;
      float sum = 0.0f;
      int count = 0;
      for (float z : n)
        if (z != kEmpty) sum += z, ++count;
      o[u] = sum / count;
      if (carry) {
        const int du[8] = {-1, 1, 0, 0, -1, 1, 1, -1}, dv[8] = {0, 0, -1, 1, -1, 1, -1, 1};
        uint8_t least = 255;
        for (int k = 0; k < 8; ++k)
          if (n[k] != kEmpty) least = std::min(least, carried.at<uint8_t>(v + dv[k], u + du[k]));
        warped_values->at<uint8_t>(v, u) = least;
      }
    }
  }
  return out;
}

BackgroundOutput BackgroundModel::Update(const BackgroundInput& input) {
  const BackgroundOptions& o = options_;
  const cv::Size size = rays_.size();
  CheckMat(input.depth, CV_32FC1, size, "depth");
  CheckMat(input.raw_mask, CV_8UC1, size, "raw_mask");
  CheckOptionalMat(input.rendered_depth, CV_32FC1, size, "rendered_depth");
  const float max_depth = static_cast<float>(o.max_depth);
  const float tol_abs = static_cast<float>(o.tolerance_abs), tol_rel = static_cast<float>(o.tolerance_rel);
  const float wp = static_cast<float>(o.prior_weight), wo = static_cast<float>(o.observation_weight);
  auto tol = [&](float z) { return tol_abs + tol_rel * z * z; };

  // 1. Prior.
  BackgroundOutput out;
  cv::Mat warped, warped_support;
  if (!background_.empty() && input.predicted_from_previous)
    warped = Warp(background_, support_, *input.predicted_from_previous, &warped_support);
  out.prior_depth = cv::Mat(size, CV_32FC1, cv::Scalar(0));
  out.background_depth = cv::Mat(size, CV_32FC1, cv::Scalar(0));
  out.support = cv::Mat(size, CV_8UC1, cv::Scalar(0));

  for (int v = 0; v < size.height; ++v) {
    const float* d = input.depth.ptr<float>(v);
    const uint8_t* m = input.raw_mask.ptr<uint8_t>(v);
    const float* r = input.rendered_depth.empty() ? nullptr : input.rendered_depth.ptr<float>(v);
    const float* w = warped.empty() ? nullptr : warped.ptr<float>(v);
    const uint8_t* ws = warped_support.empty() ? nullptr : warped_support.ptr<uint8_t>(v);
    float* p = out.prior_depth.ptr<float>(v);
    float* b = out.background_depth.ptr<float>(v);
    uint8_t* sp = out.support.ptr<uint8_t>(v);
    for (int u = 0; u < size.width; ++u) {
      float prior = 0.0f;
      int support = 0;
      if (r && Valid(r[u], max_depth)) {
        prior = r[u];
        support = 255;
      } else if (w && Valid(w[u], max_depth)) {
        prior = w[u];
        support = ws ? ws[u] : 1;
      }
      p[u] = prior;
      // 2. Fusion.
      const float z = d[u];
      const bool z_valid = Valid(z, max_depth);
      const bool observed = z_valid && m[u] == 0;
      float bg = 0.0f;
      if (prior > 0.0f && observed) {
        const float t = tol(prior);
        if (std::abs(z - prior) <= t) {
          bg = (wp * prior + wo * z) / (wp + wo);
          support = std::min(255, support + 1);
        } else if (z < prior) {
          bg = prior;  // an occluder
        } else {
          bg = z;  // what the prior held has gone
          support = 1;
        }
      } else if (prior > 0.0f) {
        bg = prior;
      } else if (observed) {
        bg = z;
        support = 1;
      }
      b[u] = bg;
      sp[u] = static_cast<uint8_t>(bg > 0.0f ? support : 0);
    }
  }

  BackgroundRefinement refined = RefineMask(input.depth, input.raw_mask, out.background_depth, out.support, o);
  out.refined_mask = std::move(refined.refined_mask);
  out.added_pixels = refined.added_pixels;
  out.removed_pixels = refined.removed_pixels;
  out.decided_fraction = refined.decided_fraction;
  background_ = out.background_depth;
  support_ = out.support;
  return out;
}

}  // namespace dypho
