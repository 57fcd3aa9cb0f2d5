#include "engine/map/map_sequence.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <numeric>
#include <optional>
#include <sstream>

#include "common/check.h"
#include "common/logging.h"
#include "engine/eval/image_metrics.h"
#include "engine/io/image_io.h"
#include "engine/map/depth_warp.h"
#include "engine/map/sensor_model.h"
#include "engine/map/trajectory_follow.h"
#include "engine/map/undistort.h"
#include "tracker/cv_view.h"
#include "tracker/tracker.h"

namespace dypho {

void SequenceMappingOptions::Validate() const {
  mapper.Validate();
  keyframes.Validate();
  DYPHO_CHECK_INPUT(iterations_per_keyframe >= 0)
      << "iterations_per_keyframe must be >= 0 (got " << iterations_per_keyframe << ")";
  DYPHO_CHECK_INPUT(final_iterations >= 0) << "final_iterations must be >= 0 (got " << final_iterations << ")";
  DYPHO_CHECK_INPUT(frame_step >= 1) << "frame_step must be >= 1 (got " << frame_step << ")";
  DYPHO_CHECK_INPUT(heldout_every >= 0) << "heldout_every must be >= 0 (got " << heldout_every << ")";
  DYPHO_CHECK_INPUT(align_heldout_iterations >= 0)
      << "align_heldout_iterations must be >= 0 (got " << align_heldout_iterations << ")";
}

namespace {

double Mean(const std::vector<FrameScore>& scores, double FrameScore::*field) {
  double sum = 0;
  size_t n = 0;
  for (const FrameScore& s : scores) {
    if (std::isfinite(s.*field)) {
      sum += s.*field;
      ++n;
    }
  }
  return n ? sum / n : std::nan("");
}

// The pose of frame `frame` (cam_from_world), or nothing.
std::optional<Rigid3d> PoseFor(const PoseSource& source, const Frame& frame, const Camera& camera,
                               std::string* why) {
  switch (source.kind) {
    case PoseSource::Kind::kGroundTruth:
      if (!frame.world_from_cam_gt) {
        *why = "no ground truth at this timestamp";
        return std::nullopt;
      }
      return frame.world_from_cam_gt->Inverse();
    case PoseSource::Kind::kTrajectory: {
      const std::optional<Rigid3d> p = InterpolatePose(source.trajectory, frame.timestamp, source.max_gap);
      if (!p) {
        *why = "outside the trajectory " + source.trajectory_path;
        return std::nullopt;
      }
      return p->Inverse();
    }
    case PoseSource::Kind::kTracker: {
      TrackerFrame tf;
      tf.timestamp = frame.timestamp;
      tf.image = CvView(frame.rgb);
      if (frame.has_depth) tf.depth = CvView(frame.depth);
      if (!frame.dynamic_mask.empty()) tf.dynamic_mask = CvView(frame.dynamic_mask);
      const TrackResult r = source.tracker->Track(tf);
      if (!IsTracked(r.status)) {
        *why = std::string("tracker: ") + TrackStatusName(r.status) + (r.message.empty() ? "" : " (" + r.message + ")");
        return std::nullopt;
      }
      return r.cam_from_world;
    }
  }
  return std::nullopt;
}

// cam_from_world at the depth timestamp from the pose source: the ground
// truth or the trajectory interpolated, or (tracker) interpolated between the
// previous tracked frame and this one.
std::optional<Rigid3d> DepthPose(const PoseSource& source, const Dataset& dataset, double t,
                                 const std::optional<std::pair<double, Rigid3d>>& previous, double frame_t,
                                 const Rigid3d& frame_pose) {
  if (source.kind == PoseSource::Kind::kTracker) {
    if (!previous || !(frame_t > previous->first) || t < previous->first || t > frame_t) return std::nullopt;
    const double a = (t - previous->first) / (frame_t - previous->first);
    return Interpolate(previous->second.Inverse(), frame_pose.Inverse(), a).Inverse();
  }
  const Trajectory& trajectory =
      source.kind == PoseSource::Kind::kGroundTruth ? dataset.ground_truth() : source.trajectory;
  const std::optional<Rigid3d> p = InterpolatePose(trajectory, t, source.max_gap);
  if (!p) return std::nullopt;
  return p->Inverse();
}

// Angular velocity of the camera at time t for the sensor model: the ground
// truth or the trajectory differentiated over +-10 ms, the tracker from the
// previous tracked frame to this one. Zero when unknown.
Eigen::Vector3d OmegaAt(const PoseSource& source, const Dataset& dataset, double t,
                        const std::optional<std::pair<double, Rigid3d>>& previous, const Rigid3d& frame_pose) {
  if (source.kind == PoseSource::Kind::kTracker) {
    if (!previous || !(t > previous->first)) return Eigen::Vector3d::Zero();
    return AngularVelocity(previous->second, previous->first, frame_pose, t);
  }
  constexpr double kHalf = 0.01;
  const std::optional<Rigid3d> a = DepthPose(source, dataset, t - kHalf, previous, t, frame_pose);
  const std::optional<Rigid3d> b = DepthPose(source, dataset, t + kHalf, previous, t, frame_pose);
  if (!a || !b) return Eigen::Vector3d::Zero();
  return AngularVelocity(*a, t - kHalf, *b, t + kHalf);
}

struct PreparedFrame {
  ImageU8 rgb;       // undistorted
  ImageF depth;      // [m], undistorted, at the colour image's pose when re-timed
  ImageU8 excluded;  // 255 = dynamic or without image data
};

PreparedFrame Prepare(const Frame& frame, const FrameInfo& info, const Undistorter& undistort,
                      const ImageU8& dynamic_mask, const SequenceMappingOptions& options, const PoseSource& source,
                      const Dataset& dataset, const Rigid3d& pose,
                      const std::optional<std::pair<double, Rigid3d>>& previous) {
  PreparedFrame p;
  p.rgb = undistort.Rgb(frame.rgb);
  p.depth = undistort.Depth(frame.depth);
  p.excluded = undistort.ExcludedPixels(dynamic_mask);
  if (options.retime_depth && !p.depth.empty() && std::abs(info.depth_timestamp - frame.timestamp) > 1e-3) {
    const std::optional<Rigid3d> depth_pose =
        DepthPose(source, dataset, info.depth_timestamp, previous, frame.timestamp, pose);
    if (depth_pose) p.depth = WarpDepth(p.depth, undistort.pinhole(), pose * depth_pose->Inverse());
  }
  return p;
}

}  // namespace

double SequenceMappingResult::MeanPsnr(bool heldout) const {
  return Mean(heldout ? heldout_scores : keyframe_scores, &FrameScore::psnr);
}
double SequenceMappingResult::MeanPsnrRaw(bool heldout) const {
  return Mean(heldout ? heldout_scores : keyframe_scores, &FrameScore::psnr_raw);
}
double SequenceMappingResult::MeanSsim(bool heldout) const {
  return Mean(heldout ? heldout_scores : keyframe_scores, &FrameScore::ssim);
}
double SequenceMappingResult::MeanDepthL1(bool heldout) const {
  return Mean(heldout ? heldout_scores : keyframe_scores, &FrameScore::depth_l1);
}

FrameScore ScoreView(const RenderedView& view, const ImageU8& rgb, const ImageF& depth, const ImageU8& dynamic_mask) {
  FrameScore s;
  ImageU8 static_mask(rgb.width(), rgb.height(), 1, 255);
  if (!dynamic_mask.empty()) {
    for (size_t i = 0; i < static_mask.size(); ++i) static_mask.data()[i] = dynamic_mask.data()[i] ? 0 : 255;
  }
  ImageF rendered = view.color;
  for (float& v : rendered.pixels()) v = std::min(1.0f, std::max(0.0f, v));
  const ImageF real = ToFloat(rgb);
  s.psnr = Psnr(rendered, real, static_mask);
  s.ssim = Ssim(rendered, real, static_mask);
  s.depth_l1 = std::nan("");
  if (!depth.empty()) {
    const ImageF rendered_depth = NormalizedDepth(view, 0.5f);
    s.depth_l1 = DepthL1(rendered_depth, depth, static_mask).l1;
  }
  return s;
}

size_t PeakRssBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) {
      std::istringstream in(line.substr(6));
      size_t kb = 0;
      in >> kb;
      return kb * 1024;
    }
  }
  return 0;
}

SequenceMappingResult MapSequence(const Dataset& dataset, const PoseSource& poses,
                                  const SequenceMappingOptions& options, std::unique_ptr<Mapper>* mapper_out,
                                  const MappingProgress& progress) {
  options.Validate();
  if (poses.kind == PoseSource::Kind::kGroundTruth) {
    DYPHO_CHECK_INPUT(dataset.has_ground_truth())
        << "dataset " << dataset.folder() << " has no groundtruth.txt: give poses another way (a trajectory file or "
        << "the tracker)";
  }
  DYPHO_CHECK_INPUT(poses.kind != PoseSource::Kind::kTracker || poses.tracker != nullptr)
      << "pose source: tracker is null";
  DYPHO_CHECK_INPUT(dataset.size() > options.first_frame)
      << "dataset " << dataset.folder() << " has " << dataset.size() << " frames; first_frame is " << options.first_frame;
  const auto start = std::chrono::steady_clock::now();
  const Undistorter undistort(dataset.camera());
  auto mapper = std::make_unique<Mapper>(undistort.pinhole(), options.mapper);
  KeyframeSelector selector(options.keyframes, dataset.camera());
  SequenceMappingResult result;
  std::unique_ptr<DenseMapper> dense;  // its own thread, beside the mapper
  if (options.dense.enabled) dense = std::make_unique<DenseMapper>(undistort.pinhole(), options.dense, false);

  std::vector<size_t> frames;
  for (size_t i = options.first_frame; i < dataset.size(); i += options.frame_step) {
    if (options.max_frames && frames.size() >= options.max_frames) break;
    frames.push_back(i);
  }
  std::vector<std::pair<size_t, Rigid3d>> non_keyframes;
  std::vector<Eigen::Vector3d> non_keyframe_omegas, keyframe_omegas;  // for the sensor model
  std::optional<std::pair<double, Rigid3d>> last_pose;  // previous frame with a pose
  struct Candidate {
    size_t frame = 0;
    KeyframeInput input;
  };
  std::optional<Candidate> candidate;  // the keyframe selector's kept candidate
  auto map_candidate = [&] {
    DYPHO_CHECK(candidate.has_value()) << "keyframe selector emitted without a candidate";
    keyframe_omegas.push_back(candidate->input.angular_velocity);
    const int id = mapper->AddKeyframe(candidate->input);
    if (dense) dense->Add(id, candidate->input);
    result.keyframe_frames.push_back(candidate->frame);
    const MapperStats st = mapper->Optimize(options.iterations_per_keyframe);
    result.loss_history.push_back(st.mean_loss);
    candidate.reset();
  };
  for (size_t k = 0; k < frames.size(); ++k) {
    const size_t i = frames[k];
    Frame frame;
    try {
      frame = dataset.Load(i);
    } catch (const InvalidInput& e) {
      if (options.strict) {
        result.stopped_at = e.message();
        DYPHO_LOG(Error) << "stopping at frame " << i << " (strict): " << e.message();
        break;
      }
      result.unreadable_frames.push_back(i);
      DYPHO_LOG(Warning) << "frame " << i << " cannot be read, skipped: " << e.message();
      continue;
    }
    if (!options.use_dataset_masks) frame.dynamic_mask = ImageU8();
    std::string why;
    const std::optional<Rigid3d> pose = PoseFor(poses, frame, dataset.camera(), &why);
    if (!pose) {
      result.frames_without_pose.push_back(i);
      DYPHO_LOG(Warning) << "frame " << i << " (t=" << FormatTimestamp(frame.timestamp)
                         << "): no pose, skipped: " << why;
      continue;
    }
    result.trajectory.timestamps.push_back(frame.timestamp);
    result.trajectory.world_from_cam.push_back(pose->Inverse());
    const std::optional<std::pair<double, Rigid3d>> previous = last_pose;
    last_pose = std::make_pair(frame.timestamp, *pose);
    const Eigen::Vector3d omega = options.mapper.sensor.active()
                                      ? OmegaAt(poses, dataset, frame.timestamp, previous, *pose)
                                      : Eigen::Vector3d::Zero();
    const KeyframeDecision decision = frame.has_depth
                                          ? selector.Offer(*pose, frame.depth, frame.rgb, frame.dynamic_mask)
                                          : KeyframeDecision();
    if (decision.keep) {
      // A better candidate in the sharpness window: the previous one is a plain frame after all.
      if (candidate) {
        non_keyframes.emplace_back(candidate->frame, candidate->input.cam_from_world);
        non_keyframe_omegas.push_back(candidate->input.angular_velocity);
      }
      const PreparedFrame prepared =
          Prepare(frame, dataset.info(i), undistort, frame.dynamic_mask, options, poses, dataset, *pose, previous);
      candidate.emplace();
      candidate->frame = i;
      candidate->input.timestamp = frame.timestamp;
      candidate->input.rgb = prepared.rgb;
      candidate->input.depth = prepared.depth;
      candidate->input.dynamic_mask = prepared.excluded;
      candidate->input.cam_from_world = *pose;
      candidate->input.angular_velocity = omega;
    } else {
      non_keyframes.emplace_back(i, *pose);
      non_keyframe_omegas.push_back(omega);
    }
    if (decision.emit) map_candidate();
    if (progress) {
      const MapperStats st = mapper->stats();
      std::ostringstream msg;
      msg << "keyframes " << st.num_keyframes << ", gaussians " << st.num_gaussians << ", loss " << st.mean_loss;
      progress(k + 1, frames.size(), msg.str());
    }
  }
  if (selector.Flush()) map_candidate();
  DYPHO_CHECK_INPUT(!result.trajectory.timestamps.empty() || frames.empty())
      << "no frame of " << dataset.folder() << " had a pose (" << result.frames_without_pose.size()
      << " without, " << result.unreadable_frames.size() << " unreadable"
      << (result.stopped_at.empty() ? "" : ", stopped at the first unreadable frame")
      << "): check --poses; nothing written";
  DYPHO_CHECK_INPUT(mapper->num_keyframes() > 0)
      << "no keyframe could be made from " << dataset.folder() << " (frames need a pose and a depth image)";
  if (options.carve_votes > 0) mapper->CarveFreeSpace(options.carve_votes);
  result.loss_before_final = mapper->MeanKeyframeLoss();
  if (options.final_iterations > 0) {
    const MapperStats st = mapper->OptimizeAll(options.final_iterations);
    result.loss_history.push_back(st.mean_loss);
  }
  result.loss_after_final = mapper->MeanKeyframeLoss();
  result.stats = mapper->stats();
  if (dense) {
    // At the final (possibly refined) keyframe poses.
    for (int k = 0; k < mapper->num_keyframes(); ++k) dense->SetPose(k, mapper->KeyframePose(k));
    result.dense_cloud = dense->Cloud();
    result.dense_stats = dense->stats();
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  if (options.evaluate) {
    const auto eval_start = std::chrono::steady_clock::now();
    const GaussianCloud cloud = mapper->Cloud();
    kernels::RasterSettings settings;
    settings.sh_degree = options.mapper.sh_degree;
    settings.num_threads = options.mapper.num_threads;
    for (float& b : settings.background) b = options.mapper.background;
    auto score = [&](size_t i, const Rigid3d& given_pose, const Eigen::Vector3d& omega, ColorResponse response,
                     bool align) {
      const Frame frame = dataset.Load(i);
      const ImageU8 dynamic = options.use_dataset_masks ? frame.dynamic_mask : ImageU8();
      const PreparedFrame prepared =
          Prepare(frame, dataset.info(i), undistort, dynamic, options, poses, dataset, given_pose, std::nullopt);
      RenderedView view = RenderView(cloud, undistort.pinhole(), given_pose, settings);
      const double psnr_raw = ScoreView(view, prepared.rgb, prepared.depth, prepared.excluded).psnr;
      Rigid3d pose = given_pose;
      if (align) {
        KeyframeInput in;
        in.timestamp = frame.timestamp;
        in.rgb = prepared.rgb;
        in.depth = prepared.depth;
        in.dynamic_mask = prepared.excluded;
        in.cam_from_world = given_pose;
        in.angular_velocity = omega;
        const FrameAlignment a = mapper->AlignFrame(in, options.align_heldout_iterations);
        pose = a.cam_from_world;
        response = a.response;
        view = RenderView(cloud, undistort.pinhole(), pose, settings);
      }
      if (options.mapper.sensor.active() && omega.norm() > 0) {
        view.color = ApplySensorModel(view.color, undistort.pinhole(), omega, options.mapper.sensor);
      }
      response.Apply(&view.color);
      FrameScore s = ScoreView(view, prepared.rgb, prepared.depth, prepared.excluded);
      s.psnr_raw = psnr_raw;
      s.frame = i;
      s.timestamp = frame.timestamp;
      return s;
    };
    for (int k = 0; k < mapper->num_keyframes(); ++k) {
      result.keyframe_scores.push_back(score(result.keyframe_frames[k], mapper->KeyframePose(k), keyframe_omegas[k], mapper->KeyframeColorResponse(k), false));
    }
    if (options.heldout_every > 0) {
      // With refine_poses the held-out frames move with the refined
      // keyframes around them (trajectory_follow.h).
      const std::optional<KeyframeFollow> follow =
          options.mapper.refine_poses ? std::optional<KeyframeFollow>(MapperKeyframeFollow(*mapper)) : std::nullopt;
      for (size_t j = options.heldout_every / 2; j < non_keyframes.size(); j += options.heldout_every) {
        const size_t i = non_keyframes[j].first;
        Rigid3d pose = non_keyframes[j].second;
        if (follow) pose = follow->MoveCamFromWorld(dataset.info(i).timestamp, pose);
        result.heldout_scores.push_back(
            score(i, pose, non_keyframe_omegas[j], ColorResponse(), options.align_heldout_iterations > 0));
      }
    }
    result.eval_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - eval_start).count();
  }
  result.peak_rss_bytes = PeakRssBytes();
  if (mapper_out) *mapper_out = std::move(mapper);
  return result;
}

}  // namespace dypho
