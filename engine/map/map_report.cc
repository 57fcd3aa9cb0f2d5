#include "engine/map/map_report.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "common/files.h"
#include "engine/eval/plots.h"
#include "engine/eval/report.h"
#include "engine/export/ply.h"
#include "engine/export/point_cloud.h"
#include "engine/io/image_io.h"
#include "engine/map/undistort.h"

namespace dypho {
namespace {

std::string Fixed(double v, int decimals) { return std::isfinite(v) ? FormatFixed(v, decimals) : "n/a"; }

}  // namespace

std::string FormatMappingSummary(const SequenceMappingResult& r) {
  std::ostringstream out;
  out << "keyframes " << r.keyframe_frames.size() << ", Gaussians " << r.stats.num_gaussians << " (added "
      << r.stats.added << ", densified " << r.stats.densified << ", pruned " << r.stats.pruned << ", carved " << r.stats.carved << "), iterations "
      << r.stats.iterations << ", mapping " << Fixed(r.seconds, 1) << " s ("
      << Fixed(r.stats.iterations / std::max(1e-9, r.stats.optimize_seconds), 2) << " it/s), peak RSS "
      << r.peak_rss_bytes / (1024 * 1024) << " MiB\n";
  out << "keyframes: PSNR " << Fixed(r.MeanPsnr(false), 2) << " dB, SSIM " << Fixed(r.MeanSsim(false), 3)
      << ", depth L1 " << Fixed(r.MeanDepthL1(false) * 100, 2) << " cm (" << r.keyframe_scores.size() << " frames)\n";
  out << "held-out:  PSNR " << Fixed(r.MeanPsnr(true), 2) << " dB, SSIM " << Fixed(r.MeanSsim(true), 3)
      << ", depth L1 " << Fixed(r.MeanDepthL1(true) * 100, 2) << " cm (" << r.heldout_scores.size() << " frames)";
  out << "\nplain renders (keyframes at their poses in the map; held-out frames at their given poses, moved with the "
         "refined keyframes under refine_poses; no sensor model, colour response or alignment): PSNR "
      << Fixed(r.MeanPsnrRaw(false), 2) << " dB keyframes, " << Fixed(r.MeanPsnrRaw(true), 2) << " dB held-out";
  if (!r.frames_without_pose.empty()) out << "\nframes without a pose (skipped): " << r.frames_without_pose.size();
  if (!r.unreadable_frames.empty()) out << "\nunreadable frames (skipped): " << r.unreadable_frames.size();
  if (!r.stopped_at.empty()) out << "\nstopped early (strict): " << r.stopped_at;
  return out.str();
}

void WriteMappingOutputs(const std::string& out_dir, const Dataset& dataset, const SequenceMappingResult& r,
                         const Mapper& mapper, int max_renders) {
  MakeOutputDirectory(out_dir);
  SavePly(mapper.Cloud(), JoinPath(out_dir, "map.ply"));
  if (r.dense_stats.keyframes_added > 0) SavePointCloudPly(r.dense_cloud, JoinPath(out_dir, "dense.ply"));
  WriteTumTrajectory(JoinPath(out_dir, "trajectory.txt"), r.trajectory);
  Trajectory keyframes;
  for (int k = 0; k < mapper.num_keyframes(); ++k) {
    keyframes.timestamps.push_back(mapper.KeyframeTimestamp(k));
    keyframes.world_from_cam.push_back(mapper.KeyframePose(k).Inverse());
  }
  WriteTumTrajectory(JoinPath(out_dir, "keyframes.txt"), keyframes);
  std::ostringstream csv;
  csv << "# frame timestamp kind psnr_db ssim depth_l1_m psnr_raw_db\n";
  auto rows = [&](const std::vector<FrameScore>& scores, const char* kind) {
    for (const FrameScore& s : scores) {
      csv << s.frame << ' ' << FormatFixed(s.timestamp, 6) << ' ' << kind << ' ' << Fixed(s.psnr, 4) << ' '
          << Fixed(s.ssim, 5) << ' ' << Fixed(s.depth_l1, 5) << ' ' << Fixed(s.psnr_raw, 4) << '\n';
    }
  };
  rows(r.keyframe_scores, "keyframe");
  rows(r.heldout_scores, "heldout");
  WriteTextAtomically(JoinPath(out_dir, "scores.csv"), csv.str());

  // Loss over Optimize calls.
  PlotSeries loss{"mean loss per keyframe", {}, {}, {200, 40, 40}};
  for (size_t i = 0; i < r.loss_history.size(); ++i) {
    loss.x.push_back(static_cast<double>(i));
    loss.y.push_back(r.loss_history[i]);
  }
  if (!loss.x.empty()) WritePlot(JoinPath(out_dir, "loss.png"), DrawLinePlot({loss}, "keyframe", "loss"));

  // Renders of a sample of keyframes and held-out frames beside the real images.
  const Undistorter undistort(dataset.camera());
  const GaussianCloud cloud = mapper.Cloud();
  kernels::RasterSettings settings;
  settings.sh_degree = mapper.options().sh_degree;
  settings.num_threads = mapper.options().num_threads;
  for (float& b : settings.background) b = mapper.options().background;
  std::vector<FramePair> pairs;
  const int nk = mapper.num_keyframes();
  const int step = std::max(1, nk / std::max(1, max_renders));
  for (int k = 0; k < nk && static_cast<int>(pairs.size()) < max_renders; k += step) {
    const Frame frame = dataset.Load(r.keyframe_frames[k]);
    RenderedView view = RenderView(cloud, undistort.pinhole(), mapper.KeyframePose(k), settings);
    mapper.KeyframeColorResponse(k).Apply(&view.color);  // as the keyframe's camera saw the colours
    std::ostringstream caption;
    caption << "keyframe " << k << " (frame " << r.keyframe_frames[k] << ")";
    if (static_cast<size_t>(k) < r.keyframe_scores.size()) {
      caption << ", PSNR " << Fixed(r.keyframe_scores[k].psnr, 1) << " dB";
    }
    pairs.push_back({ToRgb8(view.color), undistort.Rgb(frame.rgb), caption.str()});
  }
  if (!pairs.empty()) WritePlot(JoinPath(out_dir, "renders.png"), DrawFrameGrid(pairs));

  std::ostringstream md;
  md << "# Mapping report: " << dataset.name() << "\n\n";
  md << "```\n" << FormatMappingSummary(r) << "\n```\n\n";
  md << "| | frames | PSNR [dB] | SSIM | depth L1 [cm] |\n|---|---|---|---|---|\n";
  md << "| keyframes (trained) | " << r.keyframe_scores.size() << " | " << Fixed(r.MeanPsnr(false), 2) << " | "
     << Fixed(r.MeanSsim(false), 3) << " | " << Fixed(r.MeanDepthL1(false) * 100, 2) << " |\n";
  md << "| held-out frames | " << r.heldout_scores.size() << " | " << Fixed(r.MeanPsnr(true), 2) << " | "
     << Fixed(r.MeanSsim(true), 3) << " | " << Fixed(r.MeanDepthL1(true) * 100, 2) << " |\n\n";
  md << "Scores are on static pixels (dynamic mask 0), full resolution, after undistortion; renders at the "
        "keyframe's (refined) pose and colour response, held-out frames at their given pose or aligned to the map "
        "(align_heldout_iterations), both through the sensor model when it is on. The summary's last line is the "
        "plain render at the given pose.\n\n";
  if (!loss.x.empty()) md << "![loss](loss.png)\n\n";
  if (!pairs.empty()) md << "![renders](renders.png)\n";
  WriteTextAtomically(JoinPath(out_dir, "report.md"), md.str());
}

}  // namespace dypho
