#include "engine/eval/report.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "common/check.h"
#include "common/files.h"
#include "engine/eval/plots.h"

namespace dypho {
namespace {

std::string EscapeCell(const std::string& cell) {
  std::string out;
  for (char c : cell) {
    if (c == '|') {
      out += "\\|";
    } else if (c == '\n' || c == '\r') {
      out += ' ';
    } else {
      out += c;
    }
  }
  return out;
}

std::string Row(const std::vector<std::string>& cells) {
  std::string out = "|";
  for (const auto& c : cells) out += " " + EscapeCell(c) + " |";
  return out + "\n";
}

}  // namespace

MarkdownReport::MarkdownReport(const std::string& title) { text_ = "# " + title + "\n\n"; }

void MarkdownReport::AddHeading(const std::string& text, int level) {
  DYPHO_CHECK_INPUT(level >= 2 && level <= 6)
      << "MarkdownReport: heading level must be 2..6 (got " << level << ")";
  text_ += std::string(level, '#') + " " + text + "\n\n";
}

void MarkdownReport::AddParagraph(const std::string& text) { text_ += text + "\n\n"; }

void MarkdownReport::AddTable(const std::vector<std::string>& header,
                              const std::vector<std::vector<std::string>>& rows) {
  DYPHO_CHECK_INPUT(!header.empty()) << "MarkdownReport: a table needs a header";
  text_ += Row(header);
  text_ += "|";
  for (size_t i = 0; i < header.size(); ++i) text_ += " --- |";
  text_ += "\n";
  for (size_t r = 0; r < rows.size(); ++r) {
    DYPHO_CHECK_INPUT(rows[r].size() == header.size())
        << "MarkdownReport: table row " << r << " has " << rows[r].size() << " cells, the header "
        << header.size();
    text_ += Row(rows[r]);
  }
  text_ += "\n";
}

void MarkdownReport::AddImage(const std::string& relative_path, const std::string& alt_text) {
  // Angle brackets keep paths with spaces or parentheses intact.
  text_ += "![" + EscapeCell(alt_text) + "](<" + relative_path + ">)\n\n";
}

void MarkdownReport::AddCode(const std::string& text) {
  text_ += "```\n" + text + (text.empty() || text.back() != '\n' ? "\n" : "") + "```\n\n";
}

void MarkdownReport::Write(const std::string& path) const { WriteTextAtomically(path, text_); }

std::string FormatFixed(double value, int decimals) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, value);
  return buf;
}

std::vector<std::vector<std::string>> ErrorStatsRows(const ErrorStats& stats, const std::string& unit,
                                                     int decimals) {
  auto v = [&](double x) { return FormatFixed(x, decimals) + " " + unit; };
  return {{"rmse", v(stats.rmse)},
          {"mean", v(stats.mean)},
          {"median", v(stats.median)},
          {"std", v(stats.std)},
          {"min", v(stats.min)},
          {"max", v(stats.max)},
          {"count", std::to_string(stats.count)}};
}

TrajectoryEvaluation EvaluateTrajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                        const AteOptions& ate_options, const RpeOptions& rpe_options) {
  TrajectoryEvaluation e;
  e.ate_options = ate_options;
  e.rpe_options = rpe_options;
  e.ate = ComputeAte(ground_truth, estimate, ate_options);
  if (ate_options.estimate_scale) e.rpe_options.scale = e.ate.scale;
  try {
    e.rpe = ComputeRpe(ground_truth, estimate, e.rpe_options);
  } catch (const InvalidInput& error) {
    e.rpe_skipped = error.message();
  }
  return e;
}

std::string FormatEvaluation(const TrajectoryEvaluation& e) {
  std::ostringstream s;
  const ErrorStats& a = e.ate.translation;
  s << "compared_pose_pairs " << a.count << " pairs (" << e.ate.unmatched_estimates
    << " estimated poses without ground truth within " << e.ate_options.max_time_difference << " s)\n";
  s << "alignment " << (e.ate_options.estimate_scale ? "Sim(3)" : "SE(3)") << ", scale "
    << FormatFixed(e.ate.scale, 6) << "\n";
  const std::pair<const char*, double> ate_rows[] = {{"rmse", a.rmse}, {"mean", a.mean}, {"median", a.median},
                                                     {"std", a.std},   {"min", a.min},   {"max", a.max}};
  for (const auto& [name, value] : ate_rows) {
    s << "absolute_translational_error." << name << " " << FormatFixed(value, 6) << " m\n";
  }
  if (e.rpe) {
    const ErrorStats& t = e.rpe->translation;
    const ErrorStats& r = e.rpe->rotation;
    s << "rpe_pairs " << t.count << " pairs (delta " << e.rpe_options.delta << " s)\n";
    const std::pair<const char*, double> trans_rows[] = {{"rmse", t.rmse},     {"mean", t.mean},
                                                         {"median", t.median}, {"std", t.std},
                                                         {"min", t.min},       {"max", t.max}};
    for (const auto& [name, value] : trans_rows) {
      s << "translational_error." << name << " " << FormatFixed(value, 6) << " m\n";
    }
    const std::pair<const char*, double> rot_rows[] = {{"rmse", r.rmse},     {"mean", r.mean},
                                                       {"median", r.median}, {"std", r.std},
                                                       {"min", r.min},       {"max", r.max}};
    for (const auto& [name, value] : rot_rows) {
      s << "rotational_error." << name << " " << FormatFixed(value, 6) << " deg\n";
    }
  } else {
    s << "rpe not computed: " << e.rpe_skipped << "\n";
  }
  return s.str();
}

std::string WriteEvaluationReport(const std::string& dir, const Trajectory& ground_truth,
                                  const Trajectory& estimate, const TrajectoryEvaluation& e,
                                  const PlotOptions& plot_options) {
  MakeDirectories(dir);
  const std::filesystem::path root(dir);
  WritePlot((root / "trajectory_top.png").string(),
            DrawTrajectoryTopView(ground_truth, estimate, e.ate, plot_options));
  PlotOptions time_options = plot_options;
  time_options.title.clear();
  WritePlot((root / "error_over_time.png").string(),
            DrawErrorOverTime(e.ate, e.rpe ? &*e.rpe : nullptr, time_options));

  MarkdownReport report("Trajectory evaluation");
  report.AddTable({"input", "file"}, {{"ground truth", e.ground_truth_path}, {"estimate", e.estimate_path}});
  report.AddHeading("Absolute trajectory error (ATE)");
  report.AddParagraph(std::string("Positions matched by timestamp (|dt| < ") +
                      FormatFixed(e.ate_options.max_time_difference, 3) + " s), aligned with " +
                      (e.ate_options.estimate_scale ? "Sim(3)" : "SE(3)") +
                      " (Horn/Umeyama), as the TUM RGB-D benchmark's evaluate_ate.py. " +
                      std::to_string(e.ate.translation.count) + " poses compared, " +
                      std::to_string(e.ate.unmatched_estimates) +
                      " estimated poses without ground truth. Scale " + FormatFixed(e.ate.scale, 6) + ".");
  report.AddTable({"ATE", "value"}, ErrorStatsRows(e.ate.translation, "m", 4));
  report.AddImage("trajectory_top.png", "top view of the trajectories");
  report.AddHeading("Relative pose error (RPE)");
  if (e.rpe) {
    report.AddParagraph("Pose pairs " + FormatFixed(e.rpe_options.delta, 3) +
                        " s apart, as the TUM RGB-D benchmark's evaluate_rpe.py with --fixed_delta.");
    std::vector<std::vector<std::string>> rows;
    const auto t = ErrorStatsRows(e.rpe->translation, "m", 4);
    const auto r = ErrorStatsRows(e.rpe->rotation, "deg", 3);
    for (size_t i = 0; i < t.size(); ++i) rows.push_back({t[i][0], t[i][1], r[i][1]});
    report.AddTable({"RPE", "translation", "rotation"}, rows);
  } else {
    report.AddParagraph("Not computed: " + e.rpe_skipped);
  }
  report.AddImage("error_over_time.png", "error over time");
  const std::string path = (root / "report.md").string();
  report.Write(path);
  return path;
}

}  // namespace dypho
