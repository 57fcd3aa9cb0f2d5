#include "tracker/orb_tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <sstream>
#include <utility>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "common/logging.h"
#include "tracker/orb_matcher.h"

#include "tracker/orb_tracker_impl.h"

namespace dypho {

using namespace orb_internal;

bool OrbTrackerOptions::IsValid(std::string* error) const {
  if (!extractor.IsValid(error)) {
    if (error != nullptr) *error = "OrbTrackerOptions.extractor: " + *error;
    return false;
  }
  if (!optimizer.IsValid(error)) {
    if (error != nullptr) *error = "OrbTrackerOptions.optimizer: " + *error;
    return false;
  }
  if (!local_ba.IsValid(error) || !keyframe_culling.IsValid(error) || !loops.IsValid(error)) {
    if (error != nullptr) *error = "OrbTrackerOptions." + *error;
    return false;
  }
  std::ostringstream e;
  auto in01 = [](double v) { return v >= 0.0 && v <= 1.0; };
  if (!(min_depth > 0.0) || !std::isfinite(min_depth)) {
    e << "min_depth must be > 0 m (got " << min_depth << ")";
  } else if (!(max_depth > min_depth) || !std::isfinite(max_depth)) {
    e << "max_depth must be > min_depth (got " << max_depth << ")";
  } else if (!(max_depth_spread > 0.0)) {
    e << "max_depth_spread must be > 0 (got " << max_depth_spread << ")";
  } else if (!(close_depth > 0.0)) {
    e << "close_depth must be > 0 m (got " << close_depth << ")";
  } else if (min_new_points < 0) {
    e << "min_new_points must be >= 0 (got " << min_new_points << ")";
  } else if (!in01(min_point_weight)) {
    e << "min_point_weight must be in [0, 1] (got " << min_point_weight << ")";
  } else if (min_init_features < 10) {
    e << "min_init_features must be >= 10 (got " << min_init_features << ")";
  } else if (local_keyframes < 1) {
    e << "local_keyframes must be >= 1 (got " << local_keyframes << ")";
  } else if (recent_keyframes < 0) {
    e << "recent_keyframes must be >= 0 (got " << recent_keyframes << ")";
  } else if (!(coarse_radius > 0.0)) {
    e << "coarse_radius must be > 0 px (got " << coarse_radius << ")";
  } else if (!(wide_radius >= coarse_radius)) {
    e << "wide_radius must be >= coarse_radius (got " << wide_radius << ")";
  } else if (!(fine_radius > 0.0)) {
    e << "fine_radius must be > 0 px (got " << fine_radius << ")";
  } else if (max_projection_distance < 1 || max_projection_distance > 256) {
    e << "max_projection_distance must be in 1..256 (got " << max_projection_distance << ")";
  } else if (max_keyframe_distance < 1 || max_keyframe_distance > 256) {
    e << "max_keyframe_distance must be in 1..256 (got " << max_keyframe_distance << ")";
  } else if (!(match_ratio > 0.0 && match_ratio <= 1.0)) {
    e << "match_ratio must be in (0, 1] (got " << match_ratio << ")";
  } else if (!(keyframe_match_ratio > 0.0 && keyframe_match_ratio <= 1.0)) {
    e << "keyframe_match_ratio must be in (0, 1] (got " << keyframe_match_ratio << ")";
  } else if (min_coarse_inliers < 6) {
    e << "min_coarse_inliers must be >= 6 (got " << min_coarse_inliers << ")";
  } else if (last_frame_points < 0) {
    e << "last_frame_points must be >= 0 (got " << last_frame_points << ")";
  } else if (min_inliers < 6) {
    e << "min_inliers must be >= 6 (got " << min_inliers << ")";
  } else if (restart_after_lost < 0) {
    e << "restart_after_lost must be >= 0 (got " << restart_after_lost << ")";
  } else if (relocalisation_min_inliers < 6) {
    e << "relocalisation_min_inliers must be >= 6 (got " << relocalisation_min_inliers << ")";
  } else if (vocabulary_train_keyframes < 1) {
    e << "vocabulary_train_keyframes must be >= 1 (got " << vocabulary_train_keyframes << ")";
  } else if (!vocabulary.IsValid(nullptr)) {
    std::string v;
    vocabulary.IsValid(&v);
    e << v;
  } else if (!stereo.IsValid(nullptr)) {
    std::string v;
    stereo.IsValid(&v);
    e << v;
  } else if (relocalisation_candidates < 1) {
    e << "relocalisation_candidates must be >= 1 (got " << relocalisation_candidates << ")";
  } else if (keyframe_max_frames < 1) {
    e << "keyframe_max_frames must be >= 1 (got " << keyframe_max_frames << ")";
  } else if (!in01(keyframe_tracked_ratio)) {
    e << "keyframe_tracked_ratio must be in [0, 1] (got " << keyframe_tracked_ratio << ")";
  } else if (!in01(keyframe_min_coverage)) {
    e << "keyframe_min_coverage must be in [0, 1] (got " << keyframe_min_coverage << ")";
  } else if (!(rolling_shutter_readout >= 0.0 && rolling_shutter_readout < 1.0)) {
    e << "rolling_shutter_readout must be in [0, 1) s (got " << rolling_shutter_readout << ")";
  } else if (!in01(cull_min_found_ratio)) {
    e << "cull_min_found_ratio must be in [0, 1] (got " << cull_min_found_ratio << ")";
  } else if (cull_min_visible < 1) {
    e << "cull_min_visible must be >= 1 (got " << cull_min_visible << ")";
  } else {
    return true;
  }
  if (error != nullptr) *error = "OrbTrackerOptions." + e.str();
  return false;
}

OrbTracker::OrbTracker(const Camera& camera, const OrbTrackerOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  camera.Validate("OrbTracker camera");
  impl_ = std::make_unique<Impl>(camera, options);
  if (!options.vocabulary_path.empty())
    impl_->vocabulary = std::make_unique<Vocabulary>(Vocabulary::Load(options.vocabulary_path));
  impl_->vocabulary_from_file = impl_->vocabulary != nullptr;
  // Not threaded but with a fixed lag: the same worker without a thread
  // (solved on the tracking thread, applied fixed_lag frames later), so that
  // a sequential run gives the threaded run's result.
  if (options.local_ba.enabled && (options.local_ba.threaded || options.local_ba.fixed_lag > 0)) {
    Impl* m = impl_.get();
    impl_->local_ba_worker = std::make_unique<LocalBaWorker>(
        [m](LocalBaProblem problem) {
          return SolveLocalBa(m->camera, std::move(problem), m->options.local_ba, m->options.optimizer);
        },
        /*synchronous=*/!options.local_ba.threaded);
  }
  if (options.loops.enabled && (options.loops.threaded || options.loops.fixed_lag > 0)) {
    Impl* m = impl_.get();
    auto detector = std::make_shared<LoopDetector>(options.loops);  // the worker's own (its groups)
    impl_->loop_worker = std::make_unique<LoopWorker>(
        [m, detector](LoopJob job) { return m->ProcessLoopJob(detector.get(), std::move(job)); },
        /*synchronous=*/!options.loops.threaded);
  }
}

OrbTracker::~OrbTracker() = default;

const OrbTrackerOptions& OrbTracker::options() const { return impl_->options; }
const Camera& OrbTracker::camera() const { return impl_->camera; }
int OrbTracker::num_keyframes() const { return static_cast<int>(impl_->keyframes.size()); }
int OrbTracker::num_live_keyframes() const { return impl_->map.live_keyframes; }
int OrbTracker::num_map_points() const { return impl_->live_points; }
long OrbTracker::num_map_point_slots() const { return static_cast<long>(impl_->points.size()); }
int OrbTracker::num_bow_entries() const { return static_cast<int>(impl_->bow.size()); }
bool OrbTracker::has_vocabulary() const { return impl_->vocabulary != nullptr; }
const OrbBackendStats& OrbTracker::backend_stats() const { return impl_->backend; }
const OrbExtractionStats& OrbTracker::last_extraction_stats() const { return impl_->extraction_stats; }
void OrbTracker::FlushBackend() {
  impl_->CollectBackend(/*wait=*/true);
  impl_->CollectLoops(/*wait_all=*/true);
}

Rigid3d OrbTracker::KeyframePose(int id) const {
  DYPHO_CHECK_INPUT(id >= 0 && id < num_keyframes()) << "KeyframePose: no keyframe " << id << " (the tracker has "
                                                     << num_keyframes() << ")";
  return impl_->keyframes[id].cam_from_world;
}

std::vector<std::pair<double, Rigid3d>> OrbTracker::KeyframePoses() const {
  std::vector<std::pair<double, Rigid3d>> out;
  for (const Keyframe& kf : impl_->keyframes)
    if (!kf.bad) out.emplace_back(kf.timestamp, kf.cam_from_world);
  return out;
}

void OrbTracker::Reset() { impl_->Clear(); }

// Step 2 of Track for a frame with a map and a pose last frame: coarse pose
// from the last frame's points (or the reference keyframe), then the local
// map; relocalisation when both fail. Fills *pose and *optimized.
bool OrbTracker::Impl::TrackFrame(CurrentFrame* frame, const cv::Mat& gray, Rigid3d* pose,
                                  PoseOptimizerResult* optimized, bool* relocalized, std::string* why) {
  std::ostringstream trace;
  const Rigid3d predicted = Predict(frame->timestamp);
  frame_twist = (has_motion && last_dt > 0.0) ? Vector6d(last_delta.Log() / last_dt) : Vector6d::Zero();

  // Coarse: the last frame's points at the predicted pose (a wider window
  // when the first finds too few). Without a motion model the prediction is
  // only the last pose: go straight to the reference keyframe.
  bool coarse = false;
  // The last frame's temporary points go at the end of the point array for
  // the coarse stage only (no other thread reads the live array).
  const size_t real_points = points.size();
  std::vector<long> coarse_ids = last_points;
  std::vector<float> coarse_angles = last_angles;
  if (has_motion) {
    for (size_t k = 0; k < last_frame_vo.size(); ++k) {
      coarse_ids.push_back(static_cast<long>(points.size()));
      coarse_angles.push_back(last_frame_vo_angles[k]);
      points.push_back(last_frame_vo[k]);
    }
  }
  for (double radius : {options.coarse_radius, options.wide_radius}) {
    if (!has_motion) break;
    frame->ClearMatches();
    std::fill(frame->match_distance.begin(), frame->match_distance.end(), 256);
    const int matches = SearchByProjection(frame, predicted, coarse_ids, &coarse_angles, radius, false);
    trace << " coarse(r=" << radius << "): " << matches << " matches";
    if (matches < options.min_coarse_inliers) continue;
    *optimized = Optimize(frame, predicted);
    trace << ", " << optimized->num_inliers << " inliers";
    if (optimized->usable && optimized->num_inliers >= options.min_coarse_inliers) {
      *pose = optimized->cam_from_world;
      coarse = true;
      source = CoarseSource::kLastFrame;
      source_matches = matches;
      break;
    }
  }
  if (points.size() > real_points) {
    // The fine stage matches the map again: matches to temporary points go.
    for (size_t f = 0; f < frame->size(); ++f) {
      if (frame->map_points[f] < static_cast<long>(real_points)) continue;
      frame->map_points[f] = -1;
      frame->inlier[f] = 0;
      frame->match_distance[f] = 256;
    }
    points.resize(real_points);
  }
  // Fallback: descriptor matching against the reference keyframe.
  if (!coarse && reference_keyframe >= 0) {
    const int matches = MatchKeyframe(frame, reference_keyframe);
    trace << " keyframe " << reference_keyframe << ": " << matches << " matches";
    if (matches >= options.min_coarse_inliers) {
      *optimized = Optimize(frame, predicted);
      trace << ", " << optimized->num_inliers << " inliers";
      if (optimized->usable && optimized->num_inliers >= options.min_coarse_inliers) {
        *pose = optimized->cam_from_world;
        coarse = true;
        source = CoarseSource::kReferenceKeyframe;
        source_matches = matches;
      }
    }
  }

  // Fine: the local map around the coarse pose.
  bool tracked = false;
  if (coarse) {
    tracked = TrackLocalMap(frame, pose, options.fine_radius, options.min_inliers, optimized);
    trace << " fine: " << optimized->num_inliers << " of " << optimized->inliers.size() << " matches are inliers";
    if (!tracked) {
      *why = "too few inliers in the local map (" + std::to_string(optimized->num_inliers) + " < " +
             std::to_string(options.min_inliers) + ")";
    }
    // Rolling shutter without a motion model: take the motion this pose
    // implies (placing the points of a keyframe made without motion on the
    // last frame again first) and optimise once more.
    const double dt = frame->timestamp - last_timestamp;
    if (tracked && !has_motion && options.rolling_shutter_readout > 0.0 && dt > 0.0 && dt < 1.0) {
      frame_twist = (*pose * last_pose.Inverse()).Log() / dt;
      if (keyframe_without_motion >= 0 && keyframes[keyframe_without_motion].timestamp == last_timestamp)
        ReplacePointsForRollingShutter(keyframe_without_motion, frame_twist);
      keyframe_without_motion = -1;
      const PoseOptimizerResult again = Optimize(frame, *pose);
      if (again.usable && again.num_inliers >= options.min_inliers) {
        *optimized = again;
        *pose = again.cam_from_world;
      }
    }
  } else {
    *why = "no pose from the last frame or the reference keyframe";
  }

  // Relocalisation.
  if (!tracked) {
    frame->ClearMatches();
    std::string reloc_why;
    *relocalized = Relocalise(frame, gray, pose, optimized, &reloc_why);
    tracked = *relocalized;
    *why += "; " + reloc_why;
    trace << (tracked ? " relocalised" : " relocalisation failed");
  }
  DYPHO_LOG(Debug) << "orb tracker t=" << std::to_string(frame->timestamp) << ":" << trace.str();
  return tracked;
}

// Step 3 of Track: motion model, point statistics, keyframe and culling.
bool OrbTracker::Impl::UpdateMap(CurrentFrame* frame, const cv::Mat& gray, Rigid3d* pose_io, bool relocalized,
                                 int inliers, bool* loop_closed) {
  const Rigid3d& pose = *pose_io;
  const double dt = frame->timestamp - last_timestamp;
  if (!lost && !relocalized) {
    last_delta = pose * last_pose.Inverse();
    last_dt = dt;
    has_motion = true;
    // The last frame became a keyframe without knowing its motion.
    if (keyframe_without_motion >= 0 && dt > 0.0 && keyframes[keyframe_without_motion].timestamp == last_timestamp)
      ReplacePointsForRollingShutter(keyframe_without_motion, last_delta.Log() / dt);
  } else {
    has_motion = false;
  }
  keyframe_without_motion = -1;
  for (size_t i = 0; i < frame->size(); ++i) {
    if (frame->map_points[i] < 0 || !frame->inlier[i]) continue;
    MarkVisible(frame->map_points[i]);
    ++points[frame->map_points[i]].found;
  }
  ++frames_since_keyframe;
  const char* reason = frame->with_depth > 0 ? KeyframeReason(*frame, inliers) : nullptr;
  if (reason == nullptr) return false;
  DYPHO_LOG(Debug) << "orb tracker t=" << std::to_string(frame->timestamp) << ": keyframe " << keyframes.size()
                   << " (" << reason << ")";
  CreateKeyframe(frame, *pose_io, gray);
  CullPoints();
  const int kf = static_cast<int>(keyframes.size()) - 1;
  const bool closed = options.loops.enabled && CloseLoops(kf, pose_io);
  if (closed) {
    *loop_closed = true;
    // Fused points: the frame's features now hold the keyframe's (old) points.
    for (size_t i = 0; i < frame->size(); ++i) {
      if (frame->map_points[i] < 0 || !frame->inlier[i]) continue;
      frame->map_points[i] = keyframes[kf].map_points[i];
      if (frame->map_points[i] < 0) frame->inlier[i] = 0;
    }
  }
  RunBackend(kf);
  return true;
}

TrackerPrepareJob OrbTracker::PrepareJob(const cv::Mat& image) const {
  const OrbExtractor* extractor = &impl_->extractor;
  const Camera& camera = impl_->camera;
  // An image Track would refuse gets nothing prepared: Track names the error.
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3) ||
      image.cols != camera.width || image.rows != camera.height)
    return {};
  return [extractor, image, thresholds = extractor->PrepareThresholds()]() -> std::shared_ptr<const TrackerPrepared> {
    auto p = std::make_shared<orb_internal::OrbTrackerPrepared>();
    p->source = image.data;
    cv::Mat gray = image;
    if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_RGB2GRAY);
    p->orb = extractor->Prepare(gray, thresholds);
    return p;
  };
}

TrackResult OrbTracker::Track(const TrackerFrame& input) {
  Impl& m = *impl_;
  const auto t_start = Clock::now();
  TrackResult result;
  result.timestamp = input.timestamp;

  // 1. Check the input; grey image; features with depth and static weights.
  CheckTrackerFrame(input, m.camera);
  ++m.frame_counter;
  m.CollectBackend(/*wait=*/false);  // a finished threaded local BA
  result.loop_closed = m.CollectLoops(/*wait_all=*/false);  // a threaded loop closure that is due
  m.ReleasePoints();  // before this frame holds any point id
  // Work made ahead by PrepareJob for this image (else done here).
  const auto* prepared = dynamic_cast<const orb_internal::OrbTrackerPrepared*>(input.prepared.get());
  if (prepared != nullptr && (prepared->source != input.image.data || !prepared->orb)) prepared = nullptr;
  cv::Mat gray = input.image;
  if (prepared != nullptr) {
    gray = prepared->orb->gray;
  } else if (input.image.channels() == 3) {
    cv::cvtColor(input.image, m.gray_buffer, cv::COLOR_RGB2GRAY);
    gray = m.gray_buffer;
  }
  CurrentFrame frame = m.BuildFrame(input, gray, prepared != nullptr ? prepared->orb.get() : nullptr);
  m.frame_twist.setZero();
  // A new frame: no map point is matched in it yet. Without this the coarse
  // search skipped every point the last frame's local-map search had stamped,
  // i.e. most of the last frame's inliers.
  ++m.match_stamp;
  m.source = CoarseSource::kNone;
  m.source_matches = 0;
  const auto t_extracted = Clock::now();

  // 2. The pose: start the map, relocalise, or track.
  Rigid3d pose = m.last_pose;
  PoseOptimizerResult optimized;
  bool tracked = false, relocalized = false, started = false;
  std::string why;
  if (!m.initialized) {
    if (frame.with_depth >= m.options.min_init_features) {
      m.Clear();
      m.initialized = true;
      pose = Rigid3d();
      m.CreateKeyframe(&frame, pose, gray);
      tracked = started = true;
      m.source = CoarseSource::kStart;
    } else {
      why = "waiting for a frame with " + std::to_string(m.options.min_init_features) +
            " features with depth (got " + std::to_string(frame.with_depth) + " of " +
            std::to_string(frame.size()) + " features)";
    }
  } else if (m.lost) {
    tracked = relocalized = m.Relocalise(&frame, gray, &pose, &optimized, &why);
    if (!tracked && m.options.restart_after_lost > 0 && m.lost_frames >= m.options.restart_after_lost &&
        frame.with_depth >= m.options.min_init_features) {
      // A new map where the motion from before the loss leads.
      const Rigid3d start = m.PredictOverLoss(input.timestamp);
      m.Clear();
      m.initialized = true;
      pose = start;
      m.CreateKeyframe(&frame, pose, gray);
      tracked = started = true;
      m.source = CoarseSource::kStart;
      result.map_restarted = true;
      DYPHO_LOG(Info) << "orb tracker t=" << std::to_string(input.timestamp) << ": lost for " << m.lost_frames
                      << " frames, a new map starts at the predicted pose";
    } else if (!tracked) {
      ++m.lost_frames;
    }
  } else {
    tracked = m.TrackFrame(&frame, gray, &pose, &optimized, &relocalized, &why);
  }
  const auto t_tracked = Clock::now();

  // 3. Motion model, map statistics, keyframe decision, culling.
  result.is_keyframe = started;
  if (tracked && !started)
    result.is_keyframe = m.UpdateMap(&frame, gray, &pose, relocalized, optimized.num_inliers, &result.loop_closed);
  if (m.initialized && !tracked) {
    if (!m.lost) {
      m.motion_before_loss = m.has_motion;
      m.lost_frames = 1;
    }
    m.lost = true;
    m.has_motion = false;
  } else if (tracked) {
    m.lost = false;
    m.last_pose = pose;
    m.last_timestamp = input.timestamp;
    m.last_points.clear();
    m.last_angles.clear();
    for (size_t i = 0; i < frame.size(); ++i) {
      if (frame.map_points[i] < 0 || !frame.inlier[i]) continue;
      m.last_points.push_back(frame.map_points[i]);
      m.last_angles.push_back(frame.features.keypoints[i].angle);
    }
    m.MakeLastFrameVoPoints(frame, pose);
  }
  const auto t_mapped = Clock::now();

  // 4. The result.
  if (!m.initialized) {
    result.status = TrackStatus::kInitializing;
  } else if (!tracked) {
    result.status = TrackStatus::kLost;
  } else {
    result.status = relocalized ? TrackStatus::kRelocalized : TrackStatus::kOk;
  }
  result.cam_from_world = tracked ? pose : m.last_pose;
  result.message = tracked ? std::string() : why;
  result.num_matches = tracked ? static_cast<int>(optimized.inliers.size()) : 0;
  result.num_inliers = tracked ? optimized.num_inliers : 0;
  result.coarse_source = tracked ? m.source : CoarseSource::kNone;
  result.reference_keyframe = tracked ? m.reference_keyframe : -1;
  result.coarse_matches = tracked ? m.source_matches : 0;
  result.features.resize(frame.size());
  for (size_t i = 0; i < frame.size(); ++i) {
    TrackedFeature& f = result.features[i];
    const cv::KeyPoint& kp = frame.features.keypoints[i];
    f.pixel = Eigen::Vector2f(frame.features.points[i].x, frame.features.points[i].y);
    f.image_pixel = Eigen::Vector2f(kp.pt.x, kp.pt.y);
    f.weight = frame.features.weights[i];
    f.depth = frame.depth[i];
    f.level = kp.octave;
    f.map_point = (tracked && frame.inlier[i]) ? frame.map_points[i] : -1;
  }
  result.timing.extract_ms = Ms(t_start, t_extracted);
  result.timing.track_ms = Ms(t_extracted, t_tracked);
  result.timing.map_ms = Ms(t_tracked, t_mapped);
  result.timing.total_ms = Ms(t_start, Clock::now());
  return result;
}

}  // namespace dypho
