#include "tracker/orb_extractor.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <limits>
#include <sstream>
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "tracker/orb_descriptor.h"

namespace dypho {
namespace {

using orb::CentroidAngle;
using orb::ComputeDescriptor;
using orb::kDescriptorBytes;
using orb::kHalfPatch;
using orb::MakePattern;
using orb::PatternPair;

constexpr int kBorder = 16;          // [px] distance of corners from a level's border
struct Corner {
  float x, y;     // level pixels
  float score;    // FAST score
};

bool Stronger(const Corner& a, const Corner& b) {
  if (a.score != b.score) return a.score > b.score;
  if (a.y != b.y) return a.y < b.y;
  return a.x < b.x;
}

using Clock = std::chrono::steady_clock;

// CPU time of the calling thread [ms].
double ThreadCpuMs() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

// Thread CPU milliseconds since `*since`; moves `*since` to now.
double Lap(double* since) {
  const double now = ThreadCpuMs();
  const double ms = now - *since;
  *since = now;
  return ms;
}

struct LevelOutput {
  OrbStageTimes times;
  bool prepared = false;     // the main pass came from an OrbPrepared
  bool redetected = false;   // an OrbPrepared's level detected again
  std::vector<Corner> corners;  // kept, level pixels
  std::vector<float> angles;    // [deg]
  cv::Mat descriptors;          // [n, 32]
  int candidates = 0;
  double static_fraction = 1.0;
  int min_threshold = 0;
};

// FAST-9/16 with non-maximum suppression on `image` inside `inside` (grown by
// the 3 px ring FAST needs); each corner inside `inside` goes to keep(x, y, score).
template <typename Keep>
void DetectFast(const cv::Mat& image, const cv::Rect& inside, int threshold, std::vector<cv::KeyPoint>* buffer,
                Keep keep) {
  const cv::Rect area(inside.x - 3, inside.y - 3, inside.width + 6, inside.height + 6);
  buffer->clear();
  cv::FAST(image(area), *buffer, threshold, /*nonmaxSuppression=*/true, cv::FastFeatureDetector::TYPE_9_16);
  for (const cv::KeyPoint& kp : *buffer) {
    const int x = cvRound(kp.pt.x) + area.x, y = cvRound(kp.pt.y) + area.y;
    if (inside.contains(cv::Point(x, y))) keep(x, y, kp.response);
  }
}

// The blurred level the descriptors sample (7x7 Gaussian, sigma 2).
void BlurForDescriptors(const cv::Mat& level, cv::Mat* out) {
  cv::GaussianBlur(level, *out, cv::Size(7, 7), 2.0, 2.0, cv::BORDER_REFLECT_101);
}

}  // namespace

struct OrbExtractor::Impl {
  OrbExtractorOptions options;
  Camera camera;
  cv::Mat camera_matrix;  // 3x3 CV_64F
  cv::Mat distortion;     // 1x5 CV_64F
  std::vector<double> scales;
  std::vector<int> budgets;
  std::vector<cv::Size> sizes;
  std::vector<PatternPair> pattern;
  std::vector<int> u_max;
  // Buffers reused between frames (fresh pages are slow to touch).
  std::vector<cv::Mat> pyramid;
  std::vector<cv::Mat> blurred;
  std::vector<cv::Mat> masks;      // per level, CV_8U, non-zero = dynamic
  std::vector<cv::Mat> integrals;  // per level, CV_32S integral of (mask != 0)
  cv::Mat dilated;
  cv::Mat binary;
  cv::Mat dilation_kernel;
  std::vector<int> last_pass;  // per level: the main FAST pass threshold of the last Extract (0 = none yet)

  // `prepared`: the level's image, blur and main pass made ahead (or null).
  void ProcessLevel(int level, bool has_mask, const OrbPrepared* prepared, LevelOutput* out);
  // A level's detection area (corners at least kBorder px from its border);
  // empty when the level is too small or has no budget.
  cv::Rect DetectionArea(int level) const;
};

cv::Rect OrbExtractor::Impl::DetectionArea(int level) const {
  const int area_w = sizes[level].width - 2 * kBorder, area_h = sizes[level].height - 2 * kBorder;
  if (area_w < 8 || area_h < 8 || budgets[level] <= 0) return cv::Rect();
  return cv::Rect(kBorder, kBorder, area_w, area_h);
}

OrbExtractor::OrbExtractor(const OrbExtractorOptions& options, const Camera& camera)
    : impl_(std::make_unique<Impl>()) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  camera.Validate("OrbExtractor camera");
  Impl& m = *impl_;
  m.options = options;
  m.camera = camera;
  m.camera_matrix = (cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  m.distortion = cv::Mat(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) m.distortion.at<double>(i) = camera.distortion[i];

  const int levels = options.num_levels;
  m.scales.resize(levels);
  m.sizes.resize(levels);
  for (int l = 0; l < levels; ++l) {
    m.scales[l] = std::pow(options.scale_factor, l);
    m.sizes[l] = cv::Size(std::max(1, static_cast<int>(std::lround(camera.width / m.scales[l]))),
                          std::max(1, static_cast<int>(std::lround(camera.height / m.scales[l]))));
  }
  // Geometric series of budgets, rounded so that they add up to num_features.
  const double f = 1.0 / options.scale_factor;
  const double first = options.num_features * (1.0 - f) / (1.0 - std::pow(f, levels));
  double exact = 0.0;
  int given = 0;
  m.budgets.resize(levels);
  for (int l = 0; l < levels; ++l) {
    exact += first * std::pow(f, l);
    const int upto = (l == levels - 1) ? options.num_features : static_cast<int>(std::lround(exact));
    m.budgets[l] = upto - given;
    given = upto;
  }
  m.pattern = MakePattern();
  m.u_max.resize(kHalfPatch + 1);
  for (int v = 0; v <= kHalfPatch; ++v)
    m.u_max[v] = static_cast<int>(std::floor(std::sqrt(kHalfPatch * kHalfPatch - v * v + 0.25)));
  m.pyramid.resize(levels);
  m.blurred.resize(levels);
  m.masks.resize(levels);
  m.integrals.resize(levels);
  m.last_pass.assign(levels, 0);
  if (options.mask_dilation > 0) {
    const int k = 2 * options.mask_dilation + 1;
    m.dilation_kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k));
  }
}

OrbExtractor::~OrbExtractor() = default;
OrbExtractor::OrbExtractor(OrbExtractor&&) noexcept = default;
OrbExtractor& OrbExtractor::operator=(OrbExtractor&&) noexcept = default;

const OrbExtractorOptions& OrbExtractor::options() const { return impl_->options; }
double OrbExtractor::LevelScale(int level) const { return impl_->scales.at(level); }
int OrbExtractor::LevelBudget(int level) const { return impl_->budgets.at(level); }

void OrbExtractor::Impl::ProcessLevel(int level, bool has_mask, const OrbPrepared* prepared, LevelOutput* out) {
  const OrbExtractorOptions& o = options;
  double clock = ThreadCpuMs();
  const cv::Mat& image = prepared != nullptr ? prepared->pyramid[level] : pyramid[level];
  const int width = image.cols, height = image.rows;
  const cv::Rect detection_area = DetectionArea(level);
  if (detection_area.empty()) return;
  const int area_w = detection_area.width, area_h = detection_area.height;
  const int budget = budgets[level];

  // Grid of cells over the detection area.
  const int cols = std::max(1, static_cast<int>(std::lround(static_cast<double>(area_w) / o.cell_size)));
  const int rows = std::max(1, static_cast<int>(std::lround(static_cast<double>(area_h) / o.cell_size)));
  const double cell_w = static_cast<double>(area_w) / cols, cell_h = static_cast<double>(area_h) / rows;
  const int num_cells = cols * rows;
  auto cell_x0 = [&](int c) { return kBorder + static_cast<int>(std::lround(c * cell_w)); };
  auto cell_y0 = [&](int r) { return kBorder + static_cast<int>(std::lround(r * cell_h)); };

  // Static fraction per cell from the integral of the level's mask.
  std::vector<double> static_fraction(num_cells, 1.0);
  double global_static = 1.0;
  if (has_mask) {
    const cv::Mat& integral = integrals[level];
    double sum = 0.0;
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        const int x0 = cell_x0(c), x1 = cell_x0(c + 1), y0 = cell_y0(r), y1 = cell_y0(r + 1);
        const int dynamic = integral.at<int>(y1, x1) - integral.at<int>(y0, x1) - integral.at<int>(y1, x0) +
                            integral.at<int>(y0, x0);
        const int pixels = (x1 - x0) * (y1 - y0);
        const double s = pixels > 0 ? 1.0 - static_cast<double>(dynamic) / pixels : 0.0;
        static_fraction[r * cols + c] = s;
        sum += s;
      }
    }
    global_static = sum / num_cells;
  }
  out->static_fraction = global_static;

  // Thresholds and quotas per cell.
  const bool adaptive = o.adaptive_threshold;
  std::vector<int> t_init(num_cells, o.initial_fast_threshold), t_fallback(num_cells, o.fallback_fast_threshold);
  std::vector<int> quota(num_cells, 0);
  int lowest = o.fallback_fast_threshold;
  if (adaptive) {
    double active_sum = 0.0;
    for (double s : static_fraction)
      if (s >= o.min_static_fraction && s > 0.0) active_sum += s;
    if (active_sum <= 0.0) return;
    const double q = budget / active_sum;
    double exact = 0.0;
    int given = 0;
    lowest = o.initial_fast_threshold;
    for (int i = 0; i < num_cells; ++i) {
      const double s = static_fraction[i];
      if (s < o.min_static_fraction || s <= 0.0) continue;
      exact += q;
      const int upto = static_cast<int>(std::lround(exact));
      quota[i] = upto - given;
      given = upto;
      t_init[i] = AdaptiveThreshold(o.initial_fast_threshold, global_static, s, o.adaptive_exponent,
                                    o.min_fast_threshold);
      t_fallback[i] = std::min(t_init[i], AdaptiveThreshold(o.fallback_fast_threshold, global_static, s,
                                                            o.adaptive_exponent, o.min_fast_threshold));
      lowest = std::min(lowest, t_fallback[i]);
    }
  } else {
    const double q = static_cast<double>(budget) / num_cells;
    double exact = 0.0;
    int given = 0;
    for (int i = 0; i < num_cells; ++i) {
      exact += q;
      const int upto = static_cast<int>(std::lround(exact));
      quota[i] = (static_fraction[i] > 0.0) ? upto - given : 0;
      given = upto;
    }
  }
  out->min_threshold = lowest;

  // FAST corners. One pass over the level at the initial threshold of the
  // fully static cells; cells that need a lower threshold (a partly masked
  // cell under the adaptive mode, or a cell with fewer than
  // min_corners_per_cell corners, which falls back) are detected again, a
  // run of neighbouring cells at a time. With non-maximum suppression the corners scoring >= t of a pass at
  // a lower threshold are those a pass at t gives (OpenCV's FAST score does
  // not depend on the detection threshold), so one pass serves every cell
  // whose threshold is not below it. A single pass at the lowest threshold
  // would cost more: FAST slows down as the threshold drops (1.7x at 5 vs 20
  // on a synthetic 640x480 frame, 10x on a TUM frame).
  out->times.grid_ms += Lap(&clock);
  int pass_threshold = std::numeric_limits<int>::max();
  for (int i = 0; i < num_cells; ++i)
    if (quota[i] > 0 && static_fraction[i] >= 1.0) pass_threshold = std::min(pass_threshold, t_init[i]);
  if (pass_threshold == std::numeric_limits<int>::max()) pass_threshold = o.initial_fast_threshold;
  std::vector<int> col_of(width, 0), row_of(height, 0);
  for (int c = 0; c < cols; ++c)
    for (int x = cell_x0(c); x < cell_x0(c + 1); ++x) col_of[x] = c;
  for (int r = 0; r < rows; ++r)
    for (int y = cell_y0(r); y < cell_y0(r + 1); ++y) row_of[y] = r;
  last_pass[level] = pass_threshold;
  const cv::Mat* mask = has_mask ? &masks[level] : nullptr;
  std::vector<std::vector<Corner>> cells(num_cells);
  std::vector<cv::KeyPoint> fast;
  // A corner off the mask goes to its cell.
  auto add = [&](int x, int y, float score) {
    if (mask != nullptr && mask->at<uint8_t>(y, x) != 0) return;
    cells[row_of[y] * cols + col_of[x]].push_back({static_cast<float>(x), static_cast<float>(y), score});
  };
  auto detect = [&](const cv::Rect& inside, int threshold) { DetectFast(image, inside, threshold, &fast, add); };
  if (prepared != nullptr && prepared->thresholds[level] <= pass_threshold) {
    // The main pass made ahead at a threshold no higher than this one: its
    // corners scoring >= pass_threshold, in FAST's order.
    for (const cv::Vec3f& c : prepared->corners[level])
      if (c[2] >= pass_threshold) add(static_cast<int>(c[0]), static_cast<int>(c[1]), c[2]);
    out->prepared = true;
  } else {
    detect(detection_area, pass_threshold);
    out->redetected = prepared != nullptr;
  }
  // Cells that need corners below what the main pass found: a partly
  // masked cell under the adaptive mode (detected down to its fallback at
  // once, a superset whose scores decide as two passes would), or one with
  // fewer than min_corners_per_cell corners at its initial threshold.
  // A cell falls back when fewer than min_corners_per_cell of its corners
  // reach its initial threshold (and its fallback is lower).
  auto falls_back = [&](int i) {
    int strong = 0;
    for (const Corner& c : cells[i]) strong += c.score >= t_init[i];
    return strong < o.min_corners_per_cell && t_fallback[i] < t_init[i];
  };
  std::vector<int> low(num_cells, 0);  // threshold to detect the cell at again (0 = none)
  for (int i = 0; i < num_cells; ++i) {
    if (quota[i] <= 0) continue;
    if (t_init[i] < pass_threshold || falls_back(i)) low[i] = t_fallback[i];
  }
  // One FAST call per run of such cells along a row of the grid, at the
  // run's lowest threshold (per-cell calls cost more than their pixels: a
  // 3 px margin each and OpenCV's setup; 1000 cells over the pyramid).
  for (int r = 0; r < rows; ++r) {
    for (int c0 = 0; c0 < cols;) {
      if (low[r * cols + c0] == 0) {
        ++c0;
        continue;
      }
      int c1 = c0, threshold = low[r * cols + c0];
      while (c1 + 1 < cols && low[r * cols + c1 + 1] > 0) threshold = std::min(threshold, low[r * cols + ++c1]);
      for (int c = c0; c <= c1; ++c) cells[r * cols + c].clear();
      detect(cv::Rect(cell_x0(c0), cell_y0(r), cell_x0(c1 + 1) - cell_x0(c0), cell_y0(r + 1) - cell_y0(r)), threshold);
      c0 = c1 + 1;
    }
  }
  std::vector<int> cell_threshold(num_cells, 0);
  int candidates = 0;
  for (int i = 0; i < num_cells; ++i) {
    if (quota[i] <= 0) continue;
    cell_threshold[i] = low[i] > 0 && falls_back(i) ? t_fallback[i] : t_init[i];
    candidates += static_cast<int>(cells[i].size());
  }
  out->candidates = candidates;
  out->times.fast_ms += Lap(&clock);

  // Per cell: threshold (with fallback), then the strongest up to the quota.
  std::vector<Corner> kept, leftover;
  kept.reserve(budget + num_cells);
  for (int i = 0; i < num_cells; ++i) {
    std::vector<Corner>& cell = cells[i];
    if (cell.empty() || quota[i] <= 0) continue;
    const int threshold = cell_threshold[i];
    auto end = std::partition(cell.begin(), cell.end(), [&](const Corner& c) { return c.score >= threshold; });
    const int n = static_cast<int>(end - cell.begin());
    const int take = std::min(n, quota[i]);
    std::partial_sort(cell.begin(), cell.begin() + take, end, Stronger);
    kept.insert(kept.end(), cell.begin(), cell.begin() + take);
    if (adaptive) leftover.insert(leftover.end(), cell.begin() + take, end);
  }
  if (adaptive) {
    if (static_cast<int>(kept.size()) > budget) {
      std::nth_element(kept.begin(), kept.begin() + budget, kept.end(), Stronger);
      kept.resize(budget);
    } else if (static_cast<int>(kept.size()) < budget && !leftover.empty()) {
      const int extra = std::min(static_cast<int>(leftover.size()), budget - static_cast<int>(kept.size()));
      std::partial_sort(leftover.begin(), leftover.begin() + extra, leftover.end(), Stronger);
      kept.insert(kept.end(), leftover.begin(), leftover.begin() + extra);
    }
  }
  std::sort(kept.begin(), kept.end(), [](const Corner& a, const Corner& b) {
    return a.y != b.y ? a.y < b.y : a.x < b.x;
  });

  out->times.grid_ms += Lap(&clock);

  // Orientation on the level image, descriptors on its blurred copy.
  const int n = static_cast<int>(kept.size());
  out->angles.resize(n);
  for (int i = 0; i < n; ++i)
    out->angles[i] = CentroidAngle(image, static_cast<int>(kept[i].x), static_cast<int>(kept[i].y), u_max);
  out->times.orientation_ms += Lap(&clock);
  const cv::Mat& smooth = prepared != nullptr ? prepared->blurred[level] : blurred[level];
  if (prepared == nullptr) BlurForDescriptors(image, &blurred[level]);
  out->times.blur_ms += Lap(&clock);
  out->descriptors.create(n, kDescriptorBytes, CV_8UC1);
  for (int i = 0; i < n; ++i)
    ComputeDescriptor(smooth, static_cast<int>(kept[i].x), static_cast<int>(kept[i].y), out->angles[i], pattern,
                      out->descriptors.ptr<uint8_t>(i));
  out->times.descriptor_ms += Lap(&clock);
  out->corners = std::move(kept);
}

std::vector<int> OrbExtractor::PrepareThresholds(int margin) const {
  const Impl& m = *impl_;
  std::vector<int> thresholds(m.last_pass.size());
  for (size_t l = 0; l < thresholds.size(); ++l) {
    const int last = m.last_pass[l] > 0 ? m.last_pass[l] : m.options.initial_fast_threshold;
    thresholds[l] = std::clamp(last - margin, m.options.min_fast_threshold, 255);
  }
  return thresholds;
}

std::shared_ptr<const OrbPrepared> OrbExtractor::Prepare(const cv::Mat& gray,
                                                         const std::vector<int>& thresholds) const {
  const Impl& m = *impl_;
  const int levels = m.options.num_levels;
  DYPHO_CHECK_INPUT(!gray.empty() && gray.type() == CV_8UC1 && gray.cols == m.camera.width &&
                    gray.rows == m.camera.height)
      << "OrbExtractor::Prepare: the image must be CV_8UC1 grey of the camera's " << m.camera.width << "x"
      << m.camera.height << " (got " << gray.cols << "x" << gray.rows << ", type " << gray.type() << ")";
  DYPHO_CHECK_INPUT(static_cast<int>(thresholds.size()) == levels)
      << "OrbExtractor::Prepare: " << thresholds.size() << " thresholds for " << levels << " levels";
  for (int t : thresholds)
    DYPHO_CHECK_INPUT(t >= 1 && t <= 255) << "OrbExtractor::Prepare: threshold " << t << " is outside 1..255";
  auto p = std::make_shared<OrbPrepared>();
  p->gray = gray;
  p->thresholds = thresholds;
  p->pyramid.resize(levels);
  p->blurred.resize(levels);
  p->corners.resize(levels);
  p->pyramid[0] = gray;
  for (int l = 1; l < levels; ++l) cv::resize(p->pyramid[l - 1], p->pyramid[l], m.sizes[l], 0, 0, cv::INTER_LINEAR);
  std::vector<cv::KeyPoint> buffer;
  for (int l = 0; l < levels; ++l) {
    const cv::Rect inside = m.DetectionArea(l);
    if (inside.empty()) continue;
    std::vector<cv::Vec3f>& corners = p->corners[l];
    DetectFast(p->pyramid[l], inside, thresholds[l], &buffer, [&](int x, int y, float score) {
      corners.emplace_back(static_cast<float>(x), static_cast<float>(y), score);
    });
    BlurForDescriptors(p->pyramid[l], &p->blurred[l]);
  }
  return p;
}

OrbFeatures OrbExtractor::Extract(const cv::Mat& gray, const cv::Mat& dynamic_mask, const cv::Mat& static_weight,
                                  OrbExtractionStats* stats, const OrbPrepared* prepared) {
  Impl& m = *impl_;
  const Camera& cam = m.camera;
  DYPHO_CHECK_INPUT(!gray.empty()) << "OrbExtractor::Extract: the image is empty";
  DYPHO_CHECK_INPUT(gray.type() == CV_8UC1)
      << "OrbExtractor::Extract: the image must be CV_8UC1 grey (got type " << gray.type() << ")";
  DYPHO_CHECK_INPUT(gray.cols == cam.width && gray.rows == cam.height)
      << "OrbExtractor::Extract: the image is " << gray.cols << "x" << gray.rows << " but the camera is "
      << cam.width << "x" << cam.height;
  const bool has_mask = !dynamic_mask.empty();
  if (has_mask) {
    DYPHO_CHECK_INPUT(dynamic_mask.type() == CV_8UC1)
        << "OrbExtractor::Extract: dynamic_mask must be CV_8UC1 (got type " << dynamic_mask.type() << ")";
    DYPHO_CHECK_INPUT(dynamic_mask.size() == gray.size())
        << "OrbExtractor::Extract: dynamic_mask is " << dynamic_mask.cols << "x" << dynamic_mask.rows
        << " but the image is " << gray.cols << "x" << gray.rows;
  }
  if (prepared != nullptr) {
    DYPHO_CHECK_INPUT(prepared->gray.data == gray.data && prepared->gray.size() == gray.size() &&
                      static_cast<int>(prepared->pyramid.size()) == m.options.num_levels)
        << "OrbExtractor::Extract: `prepared` was made from another image or extractor";
  }
  const bool has_weight = !static_weight.empty();
  if (has_weight) {
    DYPHO_CHECK_INPUT(static_weight.type() == CV_32FC1)
        << "OrbExtractor::Extract: static_weight must be CV_32FC1 (got type " << static_weight.type() << ")";
    DYPHO_CHECK_INPUT(static_weight.size() == gray.size())
        << "OrbExtractor::Extract: static_weight is " << static_weight.cols << "x" << static_weight.rows
        << " but the image is " << gray.cols << "x" << gray.rows;
  }

  // Pyramid (chained bilinear resizes into reused buffers) and level masks.
  const Clock::time_point start = Clock::now();
  double clock = ThreadCpuMs();
  OrbStageTimes times;
  const int levels = m.options.num_levels;
  if (prepared == nullptr) {
    m.pyramid[0] = gray;
    for (int l = 1; l < levels; ++l)
      cv::resize(m.pyramid[l - 1], m.pyramid[l], m.sizes[l], 0, 0, cv::INTER_LINEAR);
  }
  times.pyramid_ms = Lap(&clock);
  if (has_mask) {
    if (m.options.mask_dilation > 0) {
      cv::dilate(dynamic_mask, m.dilated, m.dilation_kernel);
    } else {
      dynamic_mask.copyTo(m.dilated);
    }
    // Level masks by chained bilinear resizes like the image pyramid; a
    // level pixel touched by any dynamic pixel of the level below is dynamic
    // (bilinear weights of a neighbour make it non-zero). INTER_AREA from
    // level 0 would be exact but costs 1 ms per level at these scales.
    cv::threshold(m.dilated, m.masks[0], 0, 255, cv::THRESH_BINARY);
    for (int l = 1; l < levels; ++l) {
      cv::resize(m.masks[l - 1], m.masks[l], m.sizes[l], 0, 0, cv::INTER_LINEAR);
      cv::threshold(m.masks[l], m.masks[l], 0, 255, cv::THRESH_BINARY);
    }
    for (int l = 0; l < levels; ++l) {
      cv::threshold(m.masks[l], m.binary, 0, 1, cv::THRESH_BINARY);
      cv::integral(m.binary, m.integrals[l], CV_32S);
    }
  }

  times.masks_ms = Lap(&clock);

  std::vector<LevelOutput> outputs(levels);
  if (m.options.parallel_levels) {
    cv::parallel_for_(cv::Range(0, levels), [&](const cv::Range& range) {
      for (int l = range.start; l < range.end; ++l) m.ProcessLevel(l, has_mask, prepared, &outputs[l]);
    });
  } else {
    for (int l = 0; l < levels; ++l) m.ProcessLevel(l, has_mask, prepared, &outputs[l]);
  }

  for (const LevelOutput& out : outputs) {
    times.fast_ms += out.times.fast_ms;
    times.grid_ms += out.times.grid_ms;
    times.orientation_ms += out.times.orientation_ms;
    times.blur_ms += out.times.blur_ms;
    times.descriptor_ms += out.times.descriptor_ms;
  }
  clock = ThreadCpuMs();

  // Gather in level order, back to level-0 pixels.
  size_t total = 0;
  for (const LevelOutput& out : outputs) total += out.corners.size();
  OrbFeatures features;
  features.keypoints.reserve(total);
  features.descriptors.create(static_cast<int>(total), kDescriptorBytes, CV_8UC1);
  int row = 0;
  for (int l = 0; l < levels; ++l) {
    const LevelOutput& out = outputs[l];
    const double sx = static_cast<double>(cam.width) / m.sizes[l].width;
    const double sy = static_cast<double>(cam.height) / m.sizes[l].height;
    const float size = static_cast<float>(2 * kHalfPatch + 1) * static_cast<float>(m.scales[l]);
    for (size_t i = 0; i < out.corners.size(); ++i) {
      const Corner& c = out.corners[i];
      const float x0 = static_cast<float>((c.x + 0.5) * sx - 0.5);
      const float y0 = static_cast<float>((c.y + 0.5) * sy - 0.5);
      features.keypoints.emplace_back(x0, y0, size, out.angles[i], c.score, l);
    }
    if (!out.corners.empty()) {
      out.descriptors.copyTo(features.descriptors.rowRange(row, row + static_cast<int>(out.corners.size())));
      row += static_cast<int>(out.corners.size());
    }
  }

  // Undistorted positions.
  features.points.resize(total);
  for (size_t i = 0; i < total; ++i) features.points[i] = features.keypoints[i].pt;
  if (total > 0 && m.options.undistort && cam.HasDistortion()) {
    cv::Mat src(static_cast<int>(total), 1, CV_32FC2, features.points.data());
    cv::Mat dst;
    cv::undistortPoints(src, dst, m.camera_matrix, m.distortion, cv::noArray(), m.camera_matrix,
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-6));
    for (size_t i = 0; i < total; ++i) features.points[i] = dst.at<cv::Point2f>(static_cast<int>(i));
  }

  // Static weights from the soft mask.
  features.weights.assign(total, 1.0f);
  if (has_weight) {
    for (size_t i = 0; i < total; ++i) {
      const int x = std::clamp(cvRound(features.keypoints[i].pt.x), 0, cam.width - 1);
      const int y = std::clamp(cvRound(features.keypoints[i].pt.y), 0, cam.height - 1);
      const float w = static_weight.at<float>(y, x);
      features.weights[i] = std::isfinite(w) ? std::clamp(w, 0.0f, 1.0f) : 0.0f;
    }
  }

  if (stats != nullptr) {
    stats->features_per_level.assign(levels, 0);
    stats->candidates_per_level.assign(levels, 0);
    for (int l = 0; l < levels; ++l) {
      stats->features_per_level[l] = static_cast<int>(outputs[l].corners.size());
      stats->candidates_per_level[l] = outputs[l].candidates;
    }
    stats->static_fraction = outputs[0].static_fraction;
    stats->min_threshold_used = outputs[0].min_threshold;
    stats->prepared_levels = stats->redetected_levels = 0;
    for (const LevelOutput& out : outputs) {
      stats->prepared_levels += out.prepared;
      stats->redetected_levels += out.redetected;
    }
    times.gather_ms = Lap(&clock);
    times.total_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    stats->times = times;
  }
  m.pyramid[0] = cv::Mat();  // do not keep a reference to the caller's image
  return features;
}

}  // namespace dypho
