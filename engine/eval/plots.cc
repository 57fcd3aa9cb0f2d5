#include "engine/eval/plots.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "common/files.h"
#include "engine/io/image_io.h"

namespace dypho {
namespace {

// Colours in OpenCV's BGR order.
const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGrid(225, 225, 225);
const cv::Scalar kGroundTruth(120, 120, 120);
const cv::Scalar kUnmatched(190, 190, 190);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kFontScale = 0.45;
constexpr int kLeftMargin = 110;  // [px] room for the y tick labels and the y axis label

bool Finite(double v) { return std::isfinite(v); }

// A "nice" tick step (1, 2 or 5 times a power of ten) giving about `ticks`
// intervals over `range`.
double NiceStep(double range, int ticks) {
  if (!(range > 0)) return 1.0;
  const double raw = range / ticks;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / power;
  const double nice = f < 1.5 ? 1.0 : (f < 3.5 ? 2.0 : (f < 7.5 ? 5.0 : 10.0));
  return nice * power;
}

std::string TickLabel(double value, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, std::abs(value) < step * 1e-6 ? 0.0 : value);
  return buf;
}

void Text(cv::Mat& img, const std::string& text, cv::Point at, double scale = kFontScale,
          const cv::Scalar& colour = kBlack, int thickness = 1) {
  cv::putText(img, text, at, kFont, scale, colour, thickness, cv::LINE_AA);
}

cv::Size TextSize(const std::string& text, double scale = kFontScale, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, thickness, &baseline);
}

// Turbo colour for t in [0, 1] (BGR), from OpenCV's colour map.
cv::Scalar ColourFor(double t) {
  static const cv::Mat lut = [] {
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(i);
    cv::Mat coloured;
    cv::applyColorMap(ramp, coloured, cv::COLORMAP_TURBO);
    return coloured;
  }();
  const int i = std::clamp(static_cast<int>(std::lround(t * 255.0)), 0, 255);
  const cv::Vec3b c = lut.at<cv::Vec3b>(0, i);
  return cv::Scalar(c[0], c[1], c[2]);
}

ImageU8 FromBgr(const cv::Mat& bgr) {
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  ImageU8 out(rgb.cols, rgb.rows, 3);
  for (int y = 0; y < rgb.rows; ++y)
    std::memcpy(out.data() + static_cast<size_t>(y) * rgb.cols * 3, rgb.ptr(y), rgb.cols * 3);
  return out;
}

cv::Mat ToBgr(const ImageU8& image) {
  DYPHO_CHECK_INPUT(!image.empty() && (image.channels() == 1 || image.channels() == 3))
      << "frame grid: images must be non-empty with 1 or 3 channels (got " << image.width() << "x"
      << image.height() << "x" << image.channels() << ")";
  cv::Mat m(image.height(), image.width(), image.channels() == 1 ? CV_8UC1 : CV_8UC3);
  for (int y = 0; y < image.height(); ++y) {
    std::memcpy(m.ptr(y), image.data() + static_cast<size_t>(y) * image.width() * image.channels(),
                static_cast<size_t>(image.width()) * image.channels());
  }
  cv::Mat bgr;
  cv::cvtColor(m, bgr, image.channels() == 1 ? cv::COLOR_GRAY2BGR : cv::COLOR_RGB2BGR);
  return bgr;
}

// Maps data coordinates to pixels inside a plot rectangle.
struct Axes {
  cv::Rect area;          // plot area in pixels
  double x0, x1, y0, y1;  // data range shown

  cv::Point2d ToPixel(double x, double y) const {
    return {area.x + (x - x0) / (x1 - x0) * area.width,
            area.y + area.height - (y - y0) / (y1 - y0) * area.height};
  }
  cv::Point ToPoint(double x, double y) const {
    const cv::Point2d p = ToPixel(x, y);
    return {static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y))};
  }
};

// Frame, grid lines, ticks with labels and axis labels.
void DrawAxes(cv::Mat& img, const Axes& axes, const std::string& x_label, const std::string& y_label,
              int ticks) {
  const double x_step = NiceStep(axes.x1 - axes.x0, ticks);
  const double y_step = NiceStep(axes.y1 - axes.y0, ticks);
  for (double x = std::ceil(axes.x0 / x_step) * x_step; x <= axes.x1 + 1e-9 * x_step; x += x_step) {
    const cv::Point top = axes.ToPoint(x, axes.y1), bottom = axes.ToPoint(x, axes.y0);
    cv::line(img, top, bottom, kGrid, 1);
    cv::line(img, bottom, bottom + cv::Point(0, 5), kBlack, 1);
    const std::string label = TickLabel(x, x_step);
    Text(img, label, bottom + cv::Point(-TextSize(label).width / 2, 20));
  }
  for (double y = std::ceil(axes.y0 / y_step) * y_step; y <= axes.y1 + 1e-9 * y_step; y += y_step) {
    const cv::Point left = axes.ToPoint(axes.x0, y), right = axes.ToPoint(axes.x1, y);
    cv::line(img, left, right, kGrid, 1);
    cv::line(img, left, left - cv::Point(5, 0), kBlack, 1);
    const std::string label = TickLabel(y, y_step);
    Text(img, label, left + cv::Point(-TextSize(label).width - 8, 5));
  }
  cv::rectangle(img, axes.area, kBlack, 1);
  const cv::Size xs = TextSize(x_label);
  Text(img, x_label,
       cv::Point(axes.area.x + (axes.area.width - xs.width) / 2, axes.area.y + axes.area.height + 42));
  // Vertical y label: draw horizontally on a small canvas and rotate.
  const cv::Size ys = TextSize(y_label);
  cv::Mat label(ys.height + 8, ys.width + 4, CV_8UC3, kWhite);
  Text(label, y_label, cv::Point(2, ys.height + 2));
  cv::Mat rotated;
  cv::rotate(label, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int lx = 6;  // left edge; tick labels end 8 px left of the plot area
  const int ly = std::max(0, axes.area.y + (axes.area.height - rotated.rows) / 2);
  if (lx + rotated.cols <= img.cols && ly + rotated.rows <= img.rows) {
    rotated.copyTo(img(cv::Rect(lx, ly, rotated.cols, rotated.rows)));
  }
}

void DrawTitle(cv::Mat& img, const std::string& title) {
  const cv::Size s = TextSize(title, 0.6, 1);
  Text(img, title, cv::Point((img.cols - s.width) / 2, 28), 0.6, kBlack, 1);
}

// Legend box with one line sample per entry, at the top-left of `area`.
void DrawLegend(cv::Mat& img, const cv::Rect& area,
                const std::vector<std::pair<std::string, cv::Scalar>>& entries) {
  if (entries.empty()) return;
  int width = 0;
  for (const auto& e : entries) width = std::max(width, TextSize(e.first).width);
  const int row = 20;
  const cv::Rect box(area.x + 10, area.y + 10, width + 50, row * static_cast<int>(entries.size()) + 8);
  cv::rectangle(img, box, kWhite, cv::FILLED);
  cv::rectangle(img, box, kBlack, 1);
  for (size_t i = 0; i < entries.size(); ++i) {
    const int y = box.y + 14 + row * static_cast<int>(i);
    cv::line(img, cv::Point(box.x + 8, y), cv::Point(box.x + 34, y), entries[i].second, 2, cv::LINE_AA);
    Text(img, entries[i].first, cv::Point(box.x + 42, y + 5));
  }
}

// Expands [lo, hi] by a margin; a degenerate range becomes +-0.5 around it.
void PadRange(double* lo, double* hi, double fraction) {
  if (!(*hi > *lo)) {
    *lo -= 0.5;
    *hi += 0.5;
    return;
  }
  const double pad = (*hi - *lo) * fraction;
  *lo -= pad;
  *hi += pad;
}

std::array<int, 2> ChoosePlane(const std::string& plane, const std::vector<Eigen::Vector3d>& reference) {
  if (plane == "xy") return {0, 1};
  if (plane == "xz") return {0, 2};
  if (plane == "yz") return {1, 2};
  DYPHO_CHECK_INPUT(plane == "auto") << "PlotOptions::plane must be auto, xy, xz or yz (got '" << plane
                                     << "')";
  if (reference.size() < 2) return {0, 1};
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : reference) mean += p;
  mean /= static_cast<double>(reference.size());
  Eigen::Vector3d var = Eigen::Vector3d::Zero();
  for (const auto& p : reference) var += (p - mean).cwiseAbs2();
  int drop = 0;
  var.minCoeff(&drop);  // the axis along which the trajectory spreads least
  if (drop == 0) return {1, 2};
  if (drop == 1) return {0, 2};
  return {0, 1};
}

void CheckPlotOptions(const PlotOptions& options) {
  DYPHO_CHECK_INPUT(options.width >= 320 && options.height >= 240 && options.width <= 8192 &&
                    options.height <= 8192)
      << "PlotOptions: width and height must be in [320, 8192] x [240, 8192] px (got " << options.width << "x"
      << options.height << ")";
}

}  // namespace

ImageU8 DrawTrajectoryTopView(const std::vector<Eigen::Vector3d>& ground_truth,
                              const std::vector<Eigen::Vector3d>& estimate, const std::vector<double>& errors,
                              const PlotOptions& options) {
  CheckPlotOptions(options);
  DYPHO_CHECK_INPUT(errors.empty() || errors.size() == estimate.size())
      << "DrawTrajectoryTopView: " << errors.size() << " errors for " << estimate.size()
      << " estimated points";
  const std::array<int, 2> axis = ChoosePlane(options.plane, ground_truth.empty() ? estimate : ground_truth);
  const char* kNames = "xyz";

  cv::Mat img(options.height, options.width, CV_8UC3, kWhite);
  const int colour_bar_space = errors.empty() ? 20 : 110;
  const cv::Rect area(kLeftMargin, 50, options.width - kLeftMargin - colour_bar_space,
                      options.height - 50 - 70);

  // Equal-scale data range covering both trajectories.
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto* points : {&ground_truth, &estimate}) {
    for (const auto& p : *points) {
      if (!Finite(p[axis[0]]) || !Finite(p[axis[1]])) continue;
      x0 = std::min(x0, p[axis[0]]);
      x1 = std::max(x1, p[axis[0]]);
      y0 = std::min(y0, p[axis[1]]);
      y1 = std::max(y1, p[axis[1]]);
    }
  }
  if (!(x1 >= x0)) x0 = x1 = y0 = y1 = 0.0;
  PadRange(&x0, &x1, 0.05);
  PadRange(&y0, &y1, 0.05);
  const double metres_per_px = std::max((x1 - x0) / area.width, (y1 - y0) / area.height);
  const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
  Axes axes{area, cx - 0.5 * metres_per_px * area.width, cx + 0.5 * metres_per_px * area.width,
            cy - 0.5 * metres_per_px * area.height, cy + 0.5 * metres_per_px * area.height};
  DrawAxes(img, axes, std::string(1, kNames[axis[0]]) + " [m]", std::string(1, kNames[axis[1]]) + " [m]", 8);

  cv::Mat plot = img(area);  // clip drawing to the plot area
  auto local = [&](const Eigen::Vector3d& p) { return axes.ToPoint(p[axis[0]], p[axis[1]]) - area.tl(); };
  for (size_t i = 1; i < ground_truth.size(); ++i) {
    cv::line(plot, local(ground_truth[i - 1]), local(ground_truth[i]), kGroundTruth, 2, cv::LINE_AA);
  }
  double max_error = 0.0;
  for (double e : errors) {
    if (Finite(e)) max_error = std::max(max_error, e);
  }
  const double colour_scale = max_error > 0 ? max_error : 1.0;
  for (size_t i = 1; i < estimate.size(); ++i) {
    cv::Scalar colour = ColourFor(0.0);
    if (!errors.empty()) {
      const double e = Finite(errors[i]) ? errors[i] : errors[i - 1];
      colour = Finite(e) ? ColourFor(e / colour_scale) : kUnmatched;
    }
    cv::line(plot, local(estimate[i - 1]), local(estimate[i]), colour, 2, cv::LINE_AA);
  }
  if (!estimate.empty()) cv::circle(plot, local(estimate.front()), 4, kBlack, 1, cv::LINE_AA);
  if (!ground_truth.empty())
    cv::circle(plot, local(ground_truth.front()), 4, kBlack, cv::FILLED, cv::LINE_AA);

  // Colour bar for the error.
  if (!errors.empty()) {
    const cv::Rect bar(area.x + area.width + 25, area.y, 18, area.height);
    for (int y = 0; y < bar.height; ++y) {
      const double t = 1.0 - static_cast<double>(y) / std::max(1, bar.height - 1);
      cv::line(img, cv::Point(bar.x, bar.y + y), cv::Point(bar.x + bar.width - 1, bar.y + y), ColourFor(t),
               1);
    }
    cv::rectangle(img, bar, kBlack, 1);
    const double step = NiceStep(colour_scale, 5);
    for (double v = 0.0; v <= colour_scale * (1 + 1e-9); v += step) {
      const int y =
          bar.y + bar.height - 1 - static_cast<int>(std::lround(v / colour_scale * (bar.height - 1)));
      cv::line(img, cv::Point(bar.x + bar.width, y), cv::Point(bar.x + bar.width + 4, y), kBlack, 1);
      Text(img, TickLabel(v, step), cv::Point(bar.x + bar.width + 7, y + 5), 0.4);
    }
    Text(img, "error [m]", cv::Point(bar.x - 10, bar.y - 8), 0.4);
  }

  std::vector<std::pair<std::string, cv::Scalar>> legend;
  if (!ground_truth.empty()) legend.emplace_back("ground truth", kGroundTruth);
  if (!estimate.empty()) {
    legend.emplace_back(errors.empty() ? "estimate" : "estimate (colour = error)", ColourFor(0.85));
  }
  if (!errors.empty() && std::any_of(errors.begin(), errors.end(), [](double e) { return !Finite(e); })) {
    legend.emplace_back("estimate without ground truth", kUnmatched);
  }
  DrawLegend(img, area, legend);
  DrawTitle(img, options.title.empty()
                     ? std::string("Trajectory, top view (") + kNames[axis[0]] + "-" + kNames[axis[1]] + ")"
                     : options.title);
  return FromBgr(img);
}

ImageU8 DrawTrajectoryTopView(const Trajectory& ground_truth, const Trajectory& estimate,
                              const AteResult& ate, const PlotOptions& options) {
  const Trajectory aligned = AlignTrajectory(estimate, ate);
  std::vector<Eigen::Vector3d> gt_points, est_points;
  for (const Rigid3d& p : ground_truth.world_from_cam) gt_points.push_back(p.translation);
  for (const Rigid3d& p : aligned.world_from_cam) est_points.push_back(p.translation);
  std::vector<double> errors(estimate.size(), std::numeric_limits<double>::quiet_NaN());
  for (size_t k = 0; k < ate.est_indices.size(); ++k) {
    if (ate.est_indices[k] < errors.size()) errors[ate.est_indices[k]] = ate.errors[k];
  }
  PlotOptions o = options;
  if (o.title.empty()) {
    char buf[128];
    std::snprintf(buf, sizeof(buf), "Trajectory, top view - ATE RMSE %.4f m over %zu poses%s",
                  ate.translation.rmse, ate.translation.count, ate.scale != 1.0 ? " (Sim(3))" : "");
    o.title = buf;
  }
  return DrawTrajectoryTopView(gt_points, est_points, errors, o);
}

ImageU8 DrawLinePlot(const std::vector<PlotSeries>& series, const std::string& x_label,
                     const std::string& y_label, const PlotOptions& options) {
  CheckPlotOptions(options);
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y1 = 0.0;
  double y0 = 0.0;
  for (const PlotSeries& s : series) {
    DYPHO_CHECK_INPUT(s.x.size() == s.y.size()) << "DrawLinePlot: series '" << s.label << "' has "
                                                << s.x.size() << " x and " << s.y.size() << " y values";
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!Finite(s.x[i]) || !Finite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  }
  if (!(x1 >= x0)) x0 = x1 = 0.0;
  if (x1 == x0) PadRange(&x0, &x1, 0.0);
  if (y1 == y0) y1 = y0 + 1.0;
  y1 += 0.08 * (y1 - y0);

  cv::Mat img(options.height, options.width, CV_8UC3, kWhite);
  const cv::Rect area(kLeftMargin, 50, options.width - kLeftMargin - 30, options.height - 50 - 70);
  const Axes axes{area, x0, x1, y0, y1};
  DrawAxes(img, axes, x_label, y_label, 8);
  cv::Mat plot = img(area);
  std::vector<std::pair<std::string, cv::Scalar>> legend;
  for (const PlotSeries& s : series) {
    const cv::Scalar colour(s.rgb[2], s.rgb[1], s.rgb[0]);
    for (size_t i = 1; i < s.x.size(); ++i) {
      if (!Finite(s.x[i - 1]) || !Finite(s.y[i - 1]) || !Finite(s.x[i]) || !Finite(s.y[i])) continue;
      cv::line(plot, axes.ToPoint(s.x[i - 1], s.y[i - 1]) - area.tl(),
               axes.ToPoint(s.x[i], s.y[i]) - area.tl(), colour, 2, cv::LINE_AA);
    }
    if (s.x.size() == 1) cv::circle(plot, axes.ToPoint(s.x[0], s.y[0]) - area.tl(), 3, colour, cv::FILLED);
    legend.emplace_back(s.label, colour);
  }
  DrawLegend(img, area, legend);
  DrawTitle(img, options.title);
  return FromBgr(img);
}

ImageU8 DrawErrorOverTime(const AteResult& ate, const RpeResult* rpe, const PlotOptions& options) {
  const double t0 = ate.timestamps.empty() ? 0.0 : ate.timestamps.front();
  std::vector<PlotSeries> series(1);
  series[0].label = "ATE (position error after alignment)";
  series[0].rgb = {31, 119, 180};
  for (size_t k = 0; k < ate.timestamps.size(); ++k) {
    series[0].x.push_back(ate.timestamps[k] - t0);
    series[0].y.push_back(ate.errors[k]);
  }
  if (rpe != nullptr) {
    PlotSeries s;
    s.label = "RPE translation per delta";
    s.rgb = {214, 39, 40};
    for (const RpePair& p : rpe->pairs) {
      s.x.push_back(p.est_time_0 - t0);
      s.y.push_back(p.translation_error);
    }
    series.push_back(std::move(s));
  }
  PlotOptions o = options;
  if (o.title.empty()) o.title = "Trajectory error over time";
  return DrawLinePlot(series, "time [s]", "error [m]", o);
}

ImageU8 DrawFrameGrid(const std::vector<FramePair>& pairs, const FrameGridOptions& options) {
  DYPHO_CHECK_INPUT(!pairs.empty()) << "DrawFrameGrid: no frames given";
  DYPHO_CHECK_INPUT(options.cell_width >= 32 && options.cell_width <= 4096 && options.pairs_per_row >= 1)
      << "FrameGridOptions: cell_width must be in [32, 4096] px and pairs_per_row >= 1 (got "
      << options.cell_width << ", " << options.pairs_per_row << ")";
  const int w = options.cell_width;
  const int gap = 8, header = 30, caption = 26;
  int cell_height = 0;
  for (const FramePair& p : pairs) {
    for (const ImageU8* image : {&p.rendered, &p.real}) {
      DYPHO_CHECK_INPUT(!image->empty()) << "DrawFrameGrid: pair '" << p.caption << "' has an empty image";
      cell_height =
          std::max(cell_height,
                   static_cast<int>(std::lround(static_cast<double>(image->height()) * w / image->width())));
    }
  }
  const int per_row = std::min<int>(options.pairs_per_row, static_cast<int>(pairs.size()));
  const int rows = (static_cast<int>(pairs.size()) + per_row - 1) / per_row;
  const int pair_width = 2 * w + gap;
  const int width = per_row * pair_width + (per_row + 1) * gap * 2;
  const int height = header + rows * (cell_height + caption + gap) + gap;
  cv::Mat img(height, width, CV_8UC3, kWhite);
  for (int c = 0; c < per_row; ++c) {
    const int x = 2 * gap + c * (pair_width + 2 * gap);
    Text(img, "rendered", cv::Point(x + w / 2 - TextSize("rendered").width / 2, 20));
    Text(img, "real", cv::Point(x + w + gap + w / 2 - TextSize("real").width / 2, 20));
  }
  for (size_t i = 0; i < pairs.size(); ++i) {
    const int row = static_cast<int>(i) / per_row, col = static_cast<int>(i) % per_row;
    const int x = 2 * gap + col * (pair_width + 2 * gap);
    const int y = header + row * (cell_height + caption + gap);
    int k = 0;
    for (const ImageU8* image : {&pairs[i].rendered, &pairs[i].real}) {
      const cv::Mat bgr = ToBgr(*image);
      const int h = static_cast<int>(std::lround(static_cast<double>(image->height()) * w / image->width()));
      cv::Mat scaled;
      cv::resize(bgr, scaled, cv::Size(w, std::max(1, h)), 0, 0, cv::INTER_AREA);
      scaled.copyTo(img(cv::Rect(x + k * (w + gap), y, scaled.cols, scaled.rows)));
      ++k;
    }
    std::string text = pairs[i].caption;
    while (!text.empty() && TextSize(text).width > pair_width) text.pop_back();
    Text(img, text, cv::Point(x, y + cell_height + 18));
  }
  return FromBgr(img);
}

void WritePlot(const std::string& path, const ImageU8& picture) { WriteRgb8(path, picture); }

}  // namespace dypho
