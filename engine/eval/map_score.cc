#include "engine/eval/map_score.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <optional>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "common/files.h"
#include "engine/eval/image_metrics.h"
#include "engine/io/image_io.h"
#include "engine/map/depth_warp.h"
#include "engine/map/undistort.h"
#include "engine/render/render.h"
#include "tracker/cv_view.h"

namespace dypho {

void MapScoreOptions::Validate() const {
  DYPHO_CHECK_INPUT(every >= 1) << "score option every must be >= 1 (got " << every << ")";
  DYPHO_CHECK_INPUT(std::isfinite(max_gap) && max_gap > 0) << "score option max_gap must be > 0 s (got " << max_gap << ")";
  DYPHO_CHECK_INPUT(std::isfinite(background) && background >= 0 && background <= 1)
      << "score option background must be in [0, 1] (got " << background << ")";
  DYPHO_CHECK_INPUT(num_threads >= 0 && num_threads <= kMaxThreads)
      << "score option num_threads must be in [0, " << kMaxThreads << "] (got " << num_threads << ")";
  DYPHO_CHECK_INPUT(eval_downscale >= 1 && eval_downscale <= 8)
      << "score option eval_downscale must be in [1, 8] (got " << eval_downscale << ")";
  DYPHO_CHECK_INPUT(std::isfinite(min_depth) && min_depth >= 0 && std::isfinite(max_depth) &&
                    (max_depth == 0 || max_depth > min_depth))
      << "score options min_depth/max_depth must be >= 0 with max_depth 0 (no limit) or > min_depth (got "
      << min_depth << ", " << max_depth << ")";
}

namespace {

// The per-channel affine colour map real ~ a * render + b (least squares over
// the included pixels), applied to `render` in place.
void AlignColors(ImageF* render, const ImageF& real, const ImageU8& include) {
  const size_t n = static_cast<size_t>(render->width()) * render->height();
  for (int c = 0; c < 3; ++c) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0, count = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!include.data()[i]) continue;
      const double x = render->data()[3 * i + c], y = real.data()[3 * i + c];
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
      ++count;
    }
    if (count < 2) return;
    const double var = sxx - sx * sx / count;
    const double a = var > 1e-9 ? (sxy - sx * sy / count) / var : 1.0;
    const double b = (sy - a * sx) / count;
    for (size_t i = 0; i < n; ++i) {
      float& v = render->data()[3 * i + c];
      v = std::clamp(static_cast<float>(a * v + b), 0.0f, 1.0f);
    }
  }
}

template <typename T>
Image<T> Resized(const Image<T>& image, int width, int height, int interpolation) {
  if (image.empty() || (image.width() == width && image.height() == height)) return image;
  Image<T> out(width, height, image.channels());
  cv::Mat dst = CvView(out);
  cv::resize(CvView(image), dst, cv::Size(width, height), 0, 0, interpolation);
  return out;
}

double MeanOf(const std::vector<FrameMapScore>& frames, double FrameMapScore::*field) {
  double sum = 0;
  int n = 0;
  for (const FrameMapScore& f : frames) {
    if (std::isfinite(f.*field)) {
      sum += f.*field;
      ++n;
    }
  }
  return n ? sum / n : std::nan("");
}

std::string Fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace

MapScoreSummary Summarize(const std::vector<FrameMapScore>& frames) {
  MapScoreSummary s;
  s.frames = static_cast<int>(frames.size());
  if (frames.empty()) return s;
  s.psnr = MeanOf(frames, &FrameMapScore::psnr);
  s.ssim = MeanOf(frames, &FrameMapScore::ssim);
  s.depth_l1 = MeanOf(frames, &FrameMapScore::depth_l1);
  s.coverage = MeanOf(frames, &FrameMapScore::coverage);
  s.psnr_aligned = MeanOf(frames, &FrameMapScore::psnr_aligned);
  s.ssim_aligned = MeanOf(frames, &FrameMapScore::ssim_aligned);
  s.psnr_sensor = MeanOf(frames, &FrameMapScore::psnr_sensor);
  s.worst_psnr = frames[0].psnr;
  s.worst_frame = frames[0].frame;
  for (const FrameMapScore& f : frames) {
    if (f.psnr < s.worst_psnr) {
      s.worst_psnr = f.psnr;
      s.worst_frame = f.frame;
    }
  }
  return s;
}

MapScore ScoreMap(const GaussianCloud& cloud, const Dataset& dataset, const Trajectory& world_from_cam,
                  const MapScoreOptions& options, const MapScoreProgress& progress, const MapScoreVisitor& visit) {
  options.Validate();
  cloud.Validate("map to score");
  DYPHO_CHECK_INPUT(!cloud.empty()) << "the map to score has no Gaussians";
  DYPHO_CHECK_INPUT(!world_from_cam.empty()) << "the trajectory to score the map at has no poses";
  const Undistorter undistort(dataset.camera());
  const int ds = options.eval_downscale;
  Camera camera = undistort.pinhole().Scaled(1.0 / ds);
  camera.width = undistort.pinhole().width / ds;
  camera.height = undistort.pinhole().height / ds;
  kernels::RasterSettings settings;
  settings.sh_degree = static_cast<int>(std::lround(std::sqrt(cloud.sh_coeffs))) - 1;
  settings.num_threads = options.num_threads;
  for (float& b : settings.background) b = options.background;

  MapScore score;
  std::vector<std::pair<size_t, Rigid3d>> chosen;  // frame, cam_from_world
  const size_t end = options.max_frames ? std::min(dataset.size(), options.first_frame + options.max_frames)
                                        : dataset.size();
  for (size_t i = options.first_frame; i < end; ++i) {
    if (i % options.every != 0) continue;
    const std::optional<Rigid3d> pose = InterpolatePose(world_from_cam, dataset.info(i).timestamp, options.max_gap);
    if (!pose) {
      score.uncovered.push_back(i);
      continue;
    }
    chosen.emplace_back(i, pose->Inverse());
  }
  DYPHO_CHECK_INPUT(!chosen.empty() || !score.uncovered.empty())
      << "no frame to score: frames " << options.first_frame << " to " << (end == 0 ? 0 : end - 1) << " of "
      << dataset.name() << " (" << dataset.size() << " frames) hold no multiple of every=" << options.every;
  DYPHO_CHECK_INPUT(!chosen.empty()) << "the trajectory covers none of the " << score.uncovered.size()
                                     << " frames to score (every " << options.every << "th of " << dataset.name()
                                     << "): do its timestamps belong to this dataset?";
  for (size_t k = 0; k < chosen.size(); ++k) {
    const auto& [i, cam_from_world] = chosen[k];
    const Frame frame = dataset.Load(i);
    ImageU8 rgb = undistort.Rgb(frame.rgb);
    ImageF depth = frame.has_depth ? undistort.Depth(frame.depth) : ImageF();
    const FrameInfo& info = dataset.info(i);
    if (!depth.empty() && options.retime_depth && std::abs(info.depth_timestamp - frame.timestamp) > 1e-3) {
      const std::optional<Rigid3d> depth_pose = InterpolatePose(world_from_cam, info.depth_timestamp, options.max_gap);
      if (depth_pose) depth = WarpDepth(depth, undistort.pinhole(), cam_from_world * *depth_pose);
    }
    ImageU8 dynamic = options.exclude_dataset_masks ? frame.dynamic_mask : ImageU8();
    if (dynamic.empty()) {
      const auto it = options.fallback_masks.find(i);
      if (it != options.fallback_masks.end()) dynamic = it->second;
    }
    const ImageU8 excluded = undistort.ExcludedPixels(dynamic);
    rgb = Resized(rgb, camera.width, camera.height, cv::INTER_AREA);
    depth = Resized(depth, camera.width, camera.height, cv::INTER_NEAREST);
    if (options.max_depth > 0)
      for (float& d : depth.pixels())
        if (!(d >= options.min_depth && d <= options.max_depth)) d = 0.0f;
    const ImageU8 excluded_small = Resized(excluded, camera.width, camera.height, cv::INTER_NEAREST);
    ImageU8 include(camera.width, camera.height, 1);
    for (size_t p = 0; p < include.size(); ++p) include.data()[p] = excluded_small.data()[p] ? 0 : 255;

    const RenderedView view = RenderView(cloud, camera, cam_from_world, settings);
    ImageF rendered = view.color;
    for (float& v : rendered.pixels()) v = std::clamp(v, 0.0f, 1.0f);
    const ImageF real = ToFloat(rgb);
    FrameMapScore s;
    s.frame = i;
    s.timestamp = frame.timestamp;
    for (double t : options.trained_timestamps) s.trained = s.trained || std::abs(t - frame.timestamp) < 1e-3;
    s.psnr = Psnr(rendered, real, include);
    s.ssim = Ssim(rendered, real, include);
    s.depth_l1 = std::nan("");
    if (!depth.empty()) s.depth_l1 = DepthL1(NormalizedDepth(view, 0.5f), depth, include).l1;
    size_t covered = 0, counted = 0;
    for (size_t p = 0; p < include.size(); ++p) {
      if (!include.data()[p]) continue;
      ++counted;
      if (view.alpha.data()[p] > 0.5f) ++covered;
    }
    s.coverage = counted ? static_cast<double>(covered) / counted : 0.0;
    if (visit) visit(s, ToRgb8(rendered), rgb);
    s.psnr_sensor = std::nan("");
    if (options.sensor.active()) {
      constexpr double kHalf = 0.01;
      const std::optional<Rigid3d> a = InterpolatePose(world_from_cam, frame.timestamp - kHalf, options.max_gap);
      const std::optional<Rigid3d> b = InterpolatePose(world_from_cam, frame.timestamp + kHalf, options.max_gap);
      const Eigen::Vector3d omega = a && b ? AngularVelocity(a->Inverse(), frame.timestamp - kHalf, b->Inverse(),
                                                             frame.timestamp + kHalf)
                                           : Eigen::Vector3d::Zero();
      ImageF sensed = ApplySensorModel(view.color, camera, omega, options.sensor);
      for (float& v : sensed.pixels()) v = std::clamp(v, 0.0f, 1.0f);
      s.psnr_sensor = Psnr(sensed, real, include);
    }
    ImageF aligned = rendered;
    AlignColors(&aligned, real, include);
    s.psnr_aligned = Psnr(aligned, real, include);
    s.ssim_aligned = Ssim(aligned, real, include);
    score.frames.push_back(s);
    if (progress) progress(k + 1, chosen.size());
  }
  score.all = Summarize(score.frames);
  std::vector<FrameMapScore> untrained;
  for (const FrameMapScore& f : score.frames) {
    if (!f.trained) untrained.push_back(f);
  }
  score.untrained = Summarize(untrained);
  return score;
}

std::string FormatMapScoreCsv(const MapScore& score) {
  std::ostringstream out;
  out << "frame,timestamp,trained,psnr_db,ssim,depth_l1_m,coverage,psnr_aligned_db,ssim_aligned,psnr_sensor_db\n";
  for (const FrameMapScore& f : score.frames) {
    out << f.frame << "," << Fixed(f.timestamp, 6) << "," << (f.trained ? 1 : 0) << "," << Fixed(f.psnr, 3) << ","
        << Fixed(f.ssim, 4) << "," << Fixed(f.depth_l1, 4) << "," << Fixed(f.coverage, 4) << ","
        << Fixed(f.psnr_aligned, 3) << "," << Fixed(f.ssim_aligned, 4) << "," << Fixed(f.psnr_sensor, 3) << "\n";
  }
  return out.str();
}

std::string FormatMapScoreTable(const MapScore& score) {
  std::ostringstream out;
  const bool sensor = std::isfinite(score.all.psnr_sensor);
  out << "| frames | count | PSNR | SSIM | depth L1 | coverage | worst PSNR | PSNR aligned | SSIM aligned |"
      << (sensor ? " PSNR sensor model |" : "") << "\n"
      << "| --- | --- | --- | --- | --- | --- | --- | --- | --- |" << (sensor ? " --- |" : "") << "\n";
  auto row = [&](const char* name, const MapScoreSummary& s) {
    if (s.frames == 0) return;
    out << "| " << name << " | " << s.frames << " | " << Fixed(s.psnr, 2) << " dB | " << Fixed(s.ssim, 3) << " | "
        << Fixed(100 * s.depth_l1, 2) << " cm | " << Fixed(100 * s.coverage, 1) << " % | " << Fixed(s.worst_psnr, 2)
        << " dB (frame " << s.worst_frame << ") | " << Fixed(s.psnr_aligned, 2) << " dB | " << Fixed(s.ssim_aligned, 3)
        << " |";
    if (sensor) out << " " << Fixed(s.psnr_sensor, 2) << " dB |";
    out << "\n";
  };
  row("all scored", score.all);
  row("not keyframes (novel views)", score.untrained);
  return out.str();
}

}  // namespace dypho
