// Markdown run reports: headings, paragraphs, tables and linked PNG
// pictures, written atomically. Plus the trajectory-evaluation report that
// `dypho eval --plots DIR` writes (pictures + report.md) and the text it
// prints.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "engine/eval/ate.h"
#include "engine/eval/plots.h"
#include "engine/eval/trajectory.h"

namespace dypho {

class MarkdownReport {
 public:
  explicit MarkdownReport(const std::string& title);

  // A heading of `level` 2..6 (level 1 is the title).
  void AddHeading(const std::string& text, int level = 2);
  // A paragraph of plain text (Markdown is passed through).
  void AddParagraph(const std::string& text);
  // A table; every row must have as many cells as the header. '|' in cells
  // is escaped and line breaks become spaces.
  void AddTable(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);
  // A picture link; `relative_path` is relative to the report file.
  void AddImage(const std::string& relative_path, const std::string& alt_text);
  // Preformatted text (a fenced code block).
  void AddCode(const std::string& text);

  const std::string& text() const { return text_; }
  // Writes the report atomically (temporary file, then rename).
  void Write(const std::string& path) const;

 private:
  std::string text_;
};

// Number formatting used in reports and printed summaries ("%.*f"; "nan"/"inf").
std::string FormatFixed(double value, int decimals);

// Table rows "statistic | value" for an error summary with a unit.
std::vector<std::vector<std::string>> ErrorStatsRows(const ErrorStats& stats, const std::string& unit,
                                                     int decimals);

// Results of evaluating an estimated trajectory against ground truth.
struct TrajectoryEvaluation {
  std::string ground_truth_path;  // for the report
  std::string estimate_path;      // for the report
  AteOptions ate_options;         // as used
  RpeOptions rpe_options;         // as used
  AteResult ate;                  // absolute trajectory error
  std::optional<RpeResult> rpe;   // relative pose error, when it could be computed
  std::string rpe_skipped;        // why not, when !rpe
};

// Runs ATE and RPE (RPE with the ATE scale when ate_options.estimate_scale).
// A trajectory too short for RPE leaves `rpe` empty with the reason; ATE
// errors throw.
TrajectoryEvaluation EvaluateTrajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                        const AteOptions& ate_options, const RpeOptions& rpe_options);

// The plain-text summary printed by `dypho eval` (one "name value unit" per line).
std::string FormatEvaluation(const TrajectoryEvaluation& evaluation);

// Writes into `dir`: trajectory_top.png, error_over_time.png and report.md
// linking them, with ATE and RPE tables. Returns the report's path.
std::string WriteEvaluationReport(const std::string& dir, const Trajectory& ground_truth,
                                  const Trajectory& estimate, const TrajectoryEvaluation& evaluation,
                                  const PlotOptions& plot_options = PlotOptions());

}  // namespace dypho
