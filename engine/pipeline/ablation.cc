// DyPho-SLAM's ablation table (engine/pipeline/pipeline.h RunAblation).
#include <cstdio>
#include <filesystem>
#include <optional>

#include "common/check.h"
#include "common/files.h"
#include "common/logging.h"
#include "engine/eval/report.h"
#include "engine/pipeline/pipeline.h"

namespace dypho {
namespace {
namespace fs = std::filesystem;
std::string Fmt(double v, int decimals) { return FormatFixed(v, decimals); }
}  // namespace

std::vector<AblationRow> RunAblation(const PipelineOptions& options, const Dataset& dataset,
                                     const std::string& out_dir, const PipelineHooks& hooks) {
  using Variants = std::vector<std::pair<std::string, std::vector<std::string>>>;
  const Variants dypho_rows = {
      {"no masking", {"masking"}},
      {"masks, no refinement, fixed thresholds", {"refine", "adaptive"}},
      {"+ mask refinement", {"adaptive"}},
      {"+ adaptive features", {"refine"}},
      {"full system", {}},
  };
  // The nearshore paper's comparison (Zhang et al. 2025): its masks only,
  // without DyPho's flow mask and background refinement.
  const Variants shore_rows = {
      {"no masks", {"masking"}},
      {"shore mask only", {"refine", "flow", "semantic", "epipolar"}},
      {"shore + semantic", {"refine", "flow", "epipolar"}},
      {"shore + semantic + epipolar", {"refine", "flow"}},
  };
  const Variants& variants = options.preset == "shore" ? shore_rows : dypho_rows;
  const bool count_classes = HasClassMasks(dataset);
  MakeOutputDirectory(out_dir);
  std::vector<AblationRow> rows;
  for (size_t v = 0; v < variants.size(); ++v) {
    if (hooks.stop && hooks.stop->load()) break;
    PipelineOptions o = options;
    for (const std::string& stage : variants[v].second) DisableStage(&o, stage);
    AblationRow row;
    row.name = variants[v].first;
    row.disabled = variants[v].second;
    char dir[32];
    std::snprintf(dir, sizeof(dir), "row%zu", v);
    DYPHO_LOG(Info) << "ablation row " << v + 1 << "/" << variants.size() << ": " << row.name;
    PipelineHooks row_hooks = hooks;
    std::optional<FeatureClassCounter> counter;
    if (count_classes) {
      counter.emplace(dataset);
      row_hooks.on_features = [&](size_t index, const std::vector<Eigen::Vector2f>& pixels) {
        counter->Add(index, pixels);
        if (hooks.on_features) hooks.on_features(index, pixels);
      };
    }
    row.result = RunPipeline(o, dataset, (fs::path(out_dir) / dir).string(), row_hooks);
    row.has_feature_classes = count_classes;
    if (counter) row.feature_classes = counter->counts();
    rows.push_back(std::move(row));
  }
  MarkdownReport report("dypho ablate: " + dataset.name());
  report.AddParagraph("Each row is a full `dypho run` with the listed stages switched off (`--disable`), in "
                      "folders row0, row1, ...; the same options otherwise (preset `" + options.preset +
                      "`, poses `" + options.poses + "`).");
  std::vector<std::vector<std::string>> table;
  for (size_t v = 0; v < rows.size(); ++v) {
    const PipelineResult& r = rows[v].result;
    std::string disabled;
    for (const auto& s : rows[v].disabled) disabled += (disabled.empty() ? "" : ", ") + s;
    table.push_back({rows[v].name, disabled.empty() ? "-" : disabled,
                     r.has_ate ? Fmt(100 * r.ate_rmse, 2) : "-", r.has_rpe ? Fmt(100 * r.rpe_translation_rmse, 2) : "-",
                     Fmt(r.psnr, 2), Fmt(r.ssim, 3), std::to_string(r.tracked) + "/" + std::to_string(r.frames),
                     Fmt(r.tracking_fps, 1), std::to_string(r.num_gaussians)});
    if (count_classes) {
      const FeatureClassCounts& c = rows[v].feature_classes;
      for (long n : {c.features, c.water, c.sky, c.dynamic}) table.back().push_back(Fmt(c.PerFrame(n), 1));
    }
  }
  std::vector<std::string> header = {"variant", "disabled", "ATE RMSE [cm]", "RPE [cm/s]", "PSNR [dB]", "SSIM",
                                     "tracked", "tracking [fps]", "Gaussians"};
  if (count_classes) {
    report.AddParagraph("Features per frame: all the tracker extracted, and those on the exact water, sky and "
                        "moving-thing (pedestrians, boat) masks of the generator.");
    for (const char* h : {"features/frame", "on water", "on sky", "on moving"}) header.push_back(h);
  }
  report.AddTable(header, table);
  report.Write((fs::path(out_dir) / "ablation.md").string());
  return rows;
}

}  // namespace dypho
