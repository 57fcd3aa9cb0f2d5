// Evaluation pictures drawn with OpenCV (no plotting library): a top-view
// trajectory plot, an error-over-time plot and a grid of rendered vs real
// frames. Each Draw* returns an RGB image; WritePlot saves it as PNG
// atomically.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "common/image.h"
#include "engine/eval/ate.h"
#include "engine/eval/trajectory.h"

namespace dypho {

struct PlotOptions {
  int width = 960;   // [px] picture width
  int height = 720;  // [px] picture height
  // Top-view axes: "xy" (TUM and Bonn ground truth have z up; the plane
  // evaluate_ate.py plots), "xz", "yz", or "auto" (the two axes along which
  // the ground truth spreads most).
  std::string plane = "xy";
  std::string title;  // "" = a default title
};

// Top view of ground truth (grey) and estimate (coloured by `errors` [m],
// with a colour bar; points whose error is NaN are drawn in grey), axes with
// metre ticks on an equal scale, and a legend. `errors` is empty or has one
// value per estimate point.
ImageU8 DrawTrajectoryTopView(const std::vector<Eigen::Vector3d>& ground_truth,
                              const std::vector<Eigen::Vector3d>& estimate, const std::vector<double>& errors,
                              const PlotOptions& options = PlotOptions());
// The same for an ATE result: the whole estimate aligned to the ground truth,
// each matched pose coloured by its ATE error.
ImageU8 DrawTrajectoryTopView(const Trajectory& ground_truth, const Trajectory& estimate,
                              const AteResult& ate, const PlotOptions& options = PlotOptions());

// One curve of a line plot.
struct PlotSeries {
  std::string label;                    // legend text
  std::vector<double> x;                // abscissae (same length as y)
  std::vector<double> y;                // ordinates
  std::array<uint8_t, 3> rgb{0, 0, 0};  // line colour
};
// Line plot with axes, ticks and a legend. `x_label`/`y_label` name the axes
// with units.
ImageU8 DrawLinePlot(const std::vector<PlotSeries>& series, const std::string& x_label,
                     const std::string& y_label, const PlotOptions& options = PlotOptions());
// ATE [m] and, when given, RPE translation [m] over time since the first
// matched pose [s].
ImageU8 DrawErrorOverTime(const AteResult& ate, const RpeResult* rpe,
                          const PlotOptions& options = PlotOptions());

// A rendered frame beside the real one, with a caption under the pair.
struct FramePair {
  ImageU8 rendered;     // 1 or 3 channels
  ImageU8 real;         // 1 or 3 channels
  std::string caption;  // e.g. "frame 120, PSNR 24.1 dB"
};
struct FrameGridOptions {
  int cell_width = 320;   // [px] width of each image in the grid (height keeps the aspect ratio)
  int pairs_per_row = 2;  // pairs side by side in one row
};
// Grid of pairs, headed "rendered" / "real".
ImageU8 DrawFrameGrid(const std::vector<FramePair>& pairs,
                      const FrameGridOptions& options = FrameGridOptions());

// Saves an RGB picture as PNG (atomically; parent folders are created).
void WritePlot(const std::string& path, const ImageU8& picture);

}  // namespace dypho
