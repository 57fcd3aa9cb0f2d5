#include "masking/depth_box_mask.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "common/check.h"
#include "masking/mat_checks.h"

namespace dypho {
namespace {

bool ValidDepth(float z, double max_depth) { return z > 0.0f && z <= max_depth && std::isfinite(z); }

// Candidate object depths from the core's valid depths (sorted ascending),
// nearest first: the modes holding at least min_mode_fraction of them (at
// most kMaxCandidates); when no mode is that large, the largest mode alone.
constexpr int kMaxCandidates = 3;

std::vector<float> CandidateDepths(const std::vector<float>& sorted, const DepthBoxMaskOptions& o) {
  const float z_min = sorted.front();
  const float z_max = sorted.back();
  const double bin = std::max(o.bin_size, (z_max - z_min) / 2000.0);
  const int bins = static_cast<int>((z_max - z_min) / bin) + 1;
  std::vector<int> count(bins + 2, 0);  // one empty bin on either side
  for (float z : sorted) ++count[1 + std::min(bins - 1, static_cast<int>((z - z_min) / bin))];
  std::vector<int> smooth(bins + 2, 0);
  for (int i = 1; i <= bins; ++i) smooth[i] = count[i - 1] + 2 * count[i] + count[i + 1];
  const double total = static_cast<double>(sorted.size());
  std::vector<int> chosen;
  int largest = -1, largest_mass = -1;
  for (int i = 1; i <= bins; ++i) {
    // A mode: not below its left neighbour, above its right one (plateaus keep their first bin).
    if (smooth[i] < smooth[i - 1] || smooth[i] <= smooth[i + 1]) continue;
    const int mass = count[i - 1] + count[i] + count[i + 1];
    if (mass > largest_mass) largest_mass = mass, largest = i;
    if (static_cast<int>(chosen.size()) < kMaxCandidates && mass >= o.min_mode_fraction * total) chosen.push_back(i);
  }
  if (chosen.empty() && largest >= 0) chosen.push_back(largest);
  if (chosen.empty()) return {sorted[sorted.size() / 2]};
  std::vector<float> depths;
  for (int c : chosen) {
    // Median of the depths in the mode's three bins.
    const float lo = z_min + static_cast<float>((c - 2) * bin);
    const float hi = z_min + static_cast<float>((c + 1) * bin);
    const auto first = std::lower_bound(sorted.begin(), sorted.end(), lo);
    const auto last = std::upper_bound(sorted.begin(), sorted.end(), hi);
    depths.push_back(first >= last ? z_min + static_cast<float>((c - 0.5) * bin) : *(first + (last - first) / 2));
  }
  return depths;
}

// Region growing's largest depth step between neighbours at depth z.
float StepTolerance(const DepthBoxMaskOptions& o, float z) {
  return static_cast<float>(o.step_tolerance) + static_cast<float>(o.step_tolerance_rel) * z;
}

// Calls f(u, v) for the 4-neighbours of p inside an image of `size`.
template <typename F>
void ForEachNeighbour(const cv::Point& p, const cv::Size& size, F&& f) {
  static const int kDu[4] = {1, -1, 0, 0};
  static const int kDv[4] = {0, 0, 1, -1};
  for (int k = 0; k < 4; ++k) {
    const int u = p.x + kDu[k], v = p.y + kDv[k];
    if (u >= 0 && v >= 0 && u < size.width && v < size.height) f(u, v);
  }
}

// Step 3: the region at depth z_obj seeded in the core (roi coordinates)
// and grown over 4-neighbours inside the roi.
cv::Mat GrowRegion(const cv::Mat& d, const cv::Rect& core_in_roi, float z_obj, const DepthBoxMaskOptions& o) {
  const float range = static_cast<float>(o.range_tolerance);
  const float seed_tol = std::max(static_cast<float>(o.bin_size), StepTolerance(o, z_obj));
  cv::Mat region(d.size(), CV_8UC1, cv::Scalar(0));
  std::vector<cv::Point> stack;
  for (int v = core_in_roi.y; v < core_in_roi.y + core_in_roi.height; ++v) {
    const float* row = d.ptr<float>(v);
    for (int u = core_in_roi.x; u < core_in_roi.x + core_in_roi.width; ++u) {
      if (ValidDepth(row[u], o.max_depth) && std::abs(row[u] - z_obj) <= seed_tol) {
        region.at<uint8_t>(v, u) = 255;
        stack.emplace_back(u, v);
      }
    }
  }
  while (!stack.empty()) {
    const cv::Point p = stack.back();
    stack.pop_back();
    const float zp = d.at<float>(p.y, p.x);
    const float step = StepTolerance(o, zp);
    ForEachNeighbour(p, d.size(), [&](int u, int v) {
      uint8_t& r = region.at<uint8_t>(v, u);
      if (r) return;
      const float zq = d.at<float>(v, u);
      if (!ValidDepth(zq, o.max_depth) || std::abs(zq - zp) > step || std::abs(zq - z_obj) > range) return;
      r = 255;
      stack.emplace_back(u, v);
    });
  }
  return region;
}

// Whether `outer` lies on both sides of `inner` in one of the rows around
// row `cy` (a wall beside a thin person); a person behind a desk does not
// (the desk's rows hide them).
bool Around(const cv::Mat& outer, const cv::Mat& inner, double cy) {
  const int y0 = std::max(0, static_cast<int>(cy) - 2), y1 = std::min(inner.rows - 1, static_cast<int>(cy) + 2);
  for (int y = y0; y <= y1; ++y) {
    const uint8_t* in = inner.ptr<uint8_t>(y);
    const uint8_t* out = outer.ptr<uint8_t>(y);
    int first = -1, last = -1;
    for (int x = 0; x < inner.cols; ++x)
      if (in[x]) last = x, first = first < 0 ? x : first;
    if (first < 0) continue;
    bool left = false, right = false;
    for (int x = 0; x < first && !left; ++x) left = out[x] != 0;
    for (int x = last + 1; x < inner.cols && !right; ++x) right = out[x] != 0;
    if (left && right) return true;
  }
  return false;
}

// Intersection over union of the region's bounding rectangle and the roi
// (both in roi coordinates: the roi is the whole image of `region`).
double BoxIou(const cv::Mat& region) {
  const cv::Rect r = cv::boundingRect(region);
  if (r.empty()) return 0.0;
  return static_cast<double>(r.area()) / (static_cast<double>(region.cols) * region.rows);
}

// Step 3b: farther layers of the box touching the region that stand as
// tall as a person (a person behind the object, inside its box): the
// components (grown with the step tolerance) of the box pixels not in the
// region whose depth lies within range_tolerance behind z_obj, that touch
// the region, span at least min_height of the box's height and do not lie on
// both sides of the region (a wall behind a person does).
void AddLayersBehind(const cv::Mat& d, float z_obj, double min_height, const DepthBoxMaskOptions& o, cv::Mat* region) {
  const float range = static_cast<float>(o.range_tolerance);
  const cv::Moments m = cv::moments(*region, true);
  if (m.m00 <= 0) return;
  const double cy = m.m01 / m.m00;
  auto behind = [&](float z) { return ValidDepth(z, o.max_depth) && z > z_obj && z - z_obj <= range; };
  cv::Mat seen(d.size(), CV_8UC1, cv::Scalar(0));
  std::vector<cv::Point> component, stack;
  for (int v0 = 0; v0 < d.rows; ++v0) {
    for (int u0 = 0; u0 < d.cols; ++u0) {
      if (seen.at<uint8_t>(v0, u0) || region->at<uint8_t>(v0, u0) || !behind(d.at<float>(v0, u0))) continue;
      component.clear();
      stack.assign(1, cv::Point(u0, v0));
      seen.at<uint8_t>(v0, u0) = 1;
      bool touches = false;
      int top = v0, bottom = v0;
      while (!stack.empty()) {
        const cv::Point p = stack.back();
        stack.pop_back();
        component.push_back(p);
        top = std::min(top, p.y), bottom = std::max(bottom, p.y);
        const float zp = d.at<float>(p.y, p.x);
        const float step = StepTolerance(o, zp);
        ForEachNeighbour(p, d.size(), [&](int u, int v) {
          if (region->at<uint8_t>(v, u)) {
            touches = true;
            return;
          }
          uint8_t& s = seen.at<uint8_t>(v, u);
          const float zq = d.at<float>(v, u);
          if (s || !behind(zq) || std::abs(zq - zp) > step) return;
          s = 1;
          stack.emplace_back(u, v);
        });
      }
      if (!touches || bottom - top + 1 < min_height * d.rows) continue;
      cv::Mat layer(d.size(), CV_8UC1, cv::Scalar(0));
      for (const cv::Point& p : component) layer.at<uint8_t>(p) = 255;
      if (Around(layer, *region, cy)) continue;
      for (const cv::Point& p : component) region->at<uint8_t>(p) = 255;
    }
  }
}

}  // namespace

bool DepthBoxMaskOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  if (!(bin_size > 0))
    msg << "bin_size must be > 0 (got " << bin_size << ")";
  else if (!(core_width > 0 && core_width <= 1))
    msg << "core_width must be in (0, 1] (got " << core_width << ")";
  else if (!(core_height > 0 && core_height <= 1))
    msg << "core_height must be in (0, 1] (got " << core_height << ")";
  else if (!(min_mode_fraction > 0 && min_mode_fraction <= 1))
    msg << "min_mode_fraction must be in (0, 1] (got " << min_mode_fraction << ")";
  else if (!(step_tolerance >= 0))
    msg << "step_tolerance must be >= 0 (got " << step_tolerance << ")";
  else if (!(step_tolerance_rel >= 0))
    msg << "step_tolerance_rel must be >= 0 (got " << step_tolerance_rel << ")";
  else if (!(range_tolerance > 0))
    msg << "range_tolerance must be > 0 (got " << range_tolerance << ")";
  else if (!(min_valid_fraction >= 0 && min_valid_fraction <= 1))
    msg << "min_valid_fraction must be in [0, 1] (got " << min_valid_fraction << ")";
  else if (close_px < 0 || close_px > 51)
    msg << "close_px must be in 0..51 (got " << close_px << ")";
  else if (!(max_depth > 0))
    msg << "max_depth must be > 0 (got " << max_depth << ")";
  else if (whole_box_border_px < -1)
    msg << "whole_box_border_px must be >= -1 (got " << whole_box_border_px << ")";
  else if (!(min_box_iou >= 0 && min_box_iou <= 1))
    msg << "min_box_iou must be in [0, 1] (got " << min_box_iou << ")";
  else if (!(behind_min_height >= 0 && behind_min_height <= 1))
    msg << "behind_min_height must be in [0, 1] (got " << behind_min_height << ")";
  if (msg.str().empty()) return true;
  if (error) *error = msg.str();
  return false;
}

BoxMask MaskFromDepthInBox(const cv::Mat& depth, const cv::Rect& box, const DepthBoxMaskOptions& o) {
  std::string error;
  DYPHO_CHECK_INPUT(o.IsValid(&error)) << "DepthBoxMaskOptions." << error;
  CheckOptionalMat(depth, CV_32FC1, cv::Size(), "depth");
  BoxMask result;
  if (depth.empty()) {
    result.roi = box;
    result.mask = cv::Mat(box.size(), CV_8UC1, cv::Scalar(255));
    return result;
  }
  result.roi = box & cv::Rect(0, 0, depth.cols, depth.rows);
  if (result.roi.empty()) return result;
  const cv::Rect& roi = result.roi;
  result.mask = cv::Mat(roi.size(), CV_8UC1, cv::Scalar(255));
  if (o.whole_box_border_px >= 0 &&
      (roi.x <= o.whole_box_border_px || roi.x + roi.width >= depth.cols - o.whole_box_border_px))
    return result;

  // 1. Valid depths of the core.
  const int core_w = std::max(1, static_cast<int>(std::lround(roi.width * o.core_width)));
  const int core_h = std::max(1, static_cast<int>(std::lround(roi.height * o.core_height)));
  const cv::Rect core(roi.x + (roi.width - core_w) / 2, roi.y + (roi.height - core_h) / 2, core_w, core_h);
  std::vector<float> core_depths;
  core_depths.reserve(static_cast<size_t>(core.area()));
  for (int v = core.y; v < core.y + core.height; ++v) {
    const float* row = depth.ptr<float>(v);
    for (int u = core.x; u < core.x + core.width; ++u)
      if (ValidDepth(row[u], o.max_depth)) core_depths.push_back(row[u]);
  }
  if (o.whole_box || core_depths.empty() || core_depths.size() < o.min_valid_fraction * core.area()) return result;
  std::sort(core_depths.begin(), core_depths.end());

  // 2-3. The object's depth and region: the nearest candidate mode, unless
  // its region fills the box badly and a farther one fills it better (a
  // desk or a chair in front of a person standing behind it).
  const cv::Mat d = depth(roi);
  const cv::Rect core_in_roi = core - roi.tl();
  const std::vector<float> candidates = CandidateDepths(core_depths, o);
  float z_obj = candidates.front();
  cv::Mat region = GrowRegion(d, core_in_roi, z_obj, o);
  if (o.min_box_iou > 0 && candidates.size() > 1) {
    double best_iou = BoxIou(region);
    const cv::Mat nearest_region = region;  // the guard is against the nearest mode's region
    const cv::Moments nearest = cv::moments(nearest_region, true);
    for (size_t i = 1; i < candidates.size() && best_iou < o.min_box_iou && nearest.m00 > 0; ++i) {
      cv::Mat other = GrowRegion(d, core_in_roi, candidates[i], o);
      const double iou = BoxIou(other);
      if (iou > best_iou && !Around(other, nearest_region, nearest.m01 / nearest.m00)) {
        best_iou = iou;
        z_obj = candidates[i];
        region = std::move(other);
      }
    }
  }
  if (o.behind_min_height > 0) AddLayersBehind(d, z_obj, o.behind_min_height, o, &region);
  const float range = static_cast<float>(o.range_tolerance);

  // 4. Fill enclosed holes that have no depth or a depth near the object's.
  cv::Mat padded;
  cv::copyMakeBorder(region, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::floodFill(padded, cv::Point(0, 0), cv::Scalar(128), nullptr, cv::Scalar(0), cv::Scalar(0), 4);
  for (int v = 0; v < roi.height; ++v) {
    const uint8_t* prow = padded.ptr<uint8_t>(v + 1) + 1;
    const float* drow = d.ptr<float>(v);
    uint8_t* rrow = region.ptr<uint8_t>(v);
    for (int u = 0; u < roi.width; ++u) {
      if (prow[u] != 0) continue;  // region (255) or outside (128)
      if (!ValidDepth(drow[u], o.max_depth) || std::abs(drow[u] - z_obj) <= range) rrow[u] = 255;
    }
  }
  if (o.close_px > 1) {
    const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(o.close_px, o.close_px));
    cv::morphologyEx(region, region, cv::MORPH_CLOSE, kernel);
  }
  result.mask = region;
  result.depth = z_obj;
  result.from_depth = true;
  return result;
}

namespace {

// Pixels set in both masks.
int Overlap(const BoxMask& a, const BoxMask& b) {
  const cv::Rect in = a.roi & b.roi;
  if (in.empty()) return 0;
  cv::Mat both;
  cv::bitwise_and(a.mask(in - a.roi.tl()), b.mask(in - b.roi.tl()), both);
  return cv::countNonZero(both);
}

}  // namespace

std::vector<BoxMask> MasksFromDepthInBoxes(const cv::Mat& depth, const std::vector<cv::Rect>& boxes,
                                           const DepthBoxMaskOptions& o) {
  std::vector<BoxMask> masks;
  masks.reserve(boxes.size());
  for (const cv::Rect& box : boxes) masks.push_back(MaskFromDepthInBox(depth, box, o));
  if (depth.empty() || boxes.size() < 2) return masks;
  std::vector<int> count(masks.size());
  std::vector<double> fill(masks.size(), 0.0);
  for (size_t i = 0; i < masks.size(); ++i) {
    if (masks[i].roi.empty()) continue;
    count[i] = cv::countNonZero(masks[i].mask);
    fill[i] = static_cast<double>(count[i]) / masks[i].roi.area();
  }
  const float same = static_cast<float>(std::max(2 * o.bin_size, o.step_tolerance));
  std::vector<std::vector<size_t>> exclude(masks.size());
  for (size_t i = 0; i < masks.size(); ++i) {
    if (!masks[i].from_depth || count[i] == 0) continue;
    for (size_t j = 0; j < masks.size(); ++j) {
      if (j == i || !masks[j].from_depth) continue;
      const bool j_owns = fill[j] > fill[i] || (fill[j] == fill[i] && j < i);
      if (j_owns && std::abs(masks[i].depth - masks[j].depth) <= same && 2 * Overlap(masks[i], masks[j]) > count[i])
        exclude[i].push_back(j);
    }
  }
  cv::Mat without;
  for (size_t i = 0; i < masks.size(); ++i) {
    if (exclude[i].empty()) continue;
    depth.copyTo(without);
    for (size_t j : exclude[i]) without(masks[j].roi).setTo(0.0f, masks[j].mask);
    masks[i] = MaskFromDepthInBox(without, boxes[i], o);
  }
  return masks;
}

}  // namespace dypho
