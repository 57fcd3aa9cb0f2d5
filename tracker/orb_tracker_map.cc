#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "common/logging.h"
#include "tracker/orb_tracker_impl.h"

namespace dypho {
namespace orb_internal {

cv::Mat Thumbnail(const cv::Mat& gray) {
  cv::Mat small, f;
  cv::resize(gray, small, cv::Size(kThumbWidth, kThumbHeight), 0, 0, cv::INTER_AREA);
  small.convertTo(f, CV_32F);
  f -= cv::mean(f)[0];
  const double norm = cv::norm(f);
  if (norm < 1e-3) {
    f.setTo(0);
  } else {
    f /= norm;
  }
  return f;
}

}  // namespace orb_internal

using namespace orb_internal;

bool OrbTracker::Impl::Relocalise(CurrentFrame* frame, const cv::Mat& gray, Rigid3d* pose, PoseOptimizerResult* result,
                                  std::string* why) {
  if (keyframes.empty() || frame->size() < 10) {
    *why = "relocalisation: too few features (" + std::to_string(frame->size()) + ")";
    return false;
  }
  const cv::Mat thumb = Thumbnail(gray);
  std::vector<std::pair<double, int>> scores;
  for (size_t k = 0; k < keyframes.size(); ++k)
    if (!keyframes[k].bad) scores.emplace_back(thumb.dot(keyframes[k].thumbnail), static_cast<int>(k));
  std::sort(scores.begin(), scores.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second > b.second;
  });
  // Candidates: the best by bag of words, then the best by thumbnail.
  std::vector<int> candidates;
  if (options.relocalisation_bow && vocabulary && bow.size() > 0) {
    for (const BowMatch& m : bow.Query(vocabulary->Transform(frame->descriptors), options.relocalisation_candidates))
      candidates.push_back(m.entry);
  }
  const size_t from_bow = candidates.size();
  for (size_t k = 0; options.relocalisation_thumbnails && k < scores.size() &&
                     candidates.size() < from_bow + options.relocalisation_candidates;
       ++k)
    if (std::find(candidates.begin(), candidates.end(), scores[k].second) == candidates.end())
      candidates.push_back(scores[k].second);
  if (reference_keyframe >= 0 && std::find(candidates.begin(), candidates.end(), reference_keyframe) == candidates.end())
    candidates.push_back(reference_keyframe);

  int best_inliers = 0;
  for (int kf : candidates) {
    const int matches = MatchKeyframe(frame, kf);
    if (matches < kMinRelocalisationMatches) continue;
    std::vector<cv::Point3f> object;
    std::vector<cv::Point2f> image;
    std::vector<int> feature_of;
    for (size_t i = 0; i < frame->size(); ++i) {
      const long id = frame->map_points[i];
      if (id < 0) continue;
      const Eigen::Vector3d& x = points[id].position;
      object.emplace_back(static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z()));
      image.push_back(frame->features.points[i]);
      feature_of.push_back(static_cast<int>(i));
    }
    cv::Mat rvec, tvec;
    std::vector<int> pnp_inliers;
    bool ok = false;
    try {
      ok = cv::solvePnPRansac(object, image, camera_matrix, cv::noArray(), rvec, tvec, false, 200, 4.0f, 0.99,
                              pnp_inliers, cv::SOLVEPNP_EPNP);
    } catch (const cv::Exception&) {
      ok = false;
    }
    if (!ok || static_cast<int>(pnp_inliers.size()) < 10) continue;
    cv::Mat rotation;
    cv::Rodrigues(rvec, rotation);
    Eigen::Matrix3d r;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) r(a, b) = rotation.at<double>(a, b);
    Rigid3d candidate(Eigen::Quaterniond(r), Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
    if (!candidate.rotation.coeffs().allFinite() || !candidate.translation.allFinite()) continue;
    // Keep the PnP inliers, refine, then the local map.
    std::vector<char> keep(frame->size(), 0);
    for (int j : pnp_inliers) keep[feature_of[j]] = 1;
    for (size_t i = 0; i < frame->size(); ++i)
      if (!keep[i]) frame->map_points[i] = -1;
    PoseOptimizerResult refined = Optimize(frame, candidate);
    if (!refined.usable || refined.num_inliers < 10) continue;
    candidate = refined.cam_from_world;
    PoseOptimizerResult final_result;
    const bool tracked =
        TrackLocalMap(frame, &candidate, 2.0 * options.fine_radius, options.relocalisation_min_inliers, &final_result);
    best_inliers = std::max(best_inliers, final_result.num_inliers);
    if (tracked) {
      *pose = candidate;
      *result = final_result;
      source = CoarseSource::kRelocalisation;
      source_matches = matches;
      return true;
    }
  }
  frame->ClearMatches();
  *why = "relocalisation failed (best " + std::to_string(best_inliers) + " inliers, need " +
         std::to_string(options.relocalisation_min_inliers) + ")";
  return false;
}

const char* OrbTracker::Impl::KeyframeReason(const CurrentFrame& frame, int inliers) const {
  if (frames_since_keyframe >= options.keyframe_max_frames) return "interval";
  // Points of the reference keyframe seen by at least two keyframes.
  int reference_points = 0;
  if (reference_keyframe >= 0) {
    for (long id : keyframes[reference_keyframe].map_points)
      if (id >= 0 && !points[id].bad && points[id].keyframes.size() >= 2) ++reference_points;
  }
  if (inliers < options.keyframe_tracked_ratio * reference_points) return "tracked ratio";
  // Near points tracked vs not tracked (as ORB-SLAM for RGB-D).
  int close_tracked = 0, close_untracked = 0;
  for (size_t i = 0; i < frame.size(); ++i) {
    if (frame.depth[i] <= 0.0f || frame.depth[i] > options.close_depth) continue;
    if (frame.inlier[i]) {
      ++close_tracked;
    } else {
      ++close_untracked;
    }
  }
  if (close_tracked < 100 && close_untracked > 70) return "near points";
  // Coverage of the cells that have near features with depth (those a
  // keyframe would turn into points).
  std::vector<char> with_depth(kCoverageCols * kCoverageRows, 0), covered(kCoverageCols * kCoverageRows, 0);
  for (size_t i = 0; i < frame.size(); ++i) {
    const cv::Point2f& p = frame.features.keypoints[i].pt;
    const int c = std::clamp(static_cast<int>(p.x * kCoverageCols / camera.width), 0, kCoverageCols - 1);
    const int r = std::clamp(static_cast<int>(p.y * kCoverageRows / camera.height), 0, kCoverageRows - 1);
    if (frame.depth[i] > 0.0f && frame.depth[i] <= options.close_depth) with_depth[r * kCoverageCols + c] = 1;
    if (frame.inlier[i]) covered[r * kCoverageCols + c] = 1;
  }
  int cells = 0, hit = 0;
  for (size_t c = 0; c < with_depth.size(); ++c) {
    cells += with_depth[c];
    hit += with_depth[c] && covered[c];
  }
  if (cells > 0 && hit < options.keyframe_min_coverage * cells) return "coverage";
  return nullptr;
}

MapPoint OrbTracker::Impl::MakePoint(const CurrentFrame& frame, int i, const Rigid3d& world_from_cam) const {
  const cv::Point2f& px = frame.features.points[i];
  const Eigen::Vector3d in_cam = camera.Unproject(Eigen::Vector2d(px.x, px.y), frame.depth[i]);
  MapPoint mp;
  // Rolling shutter: the row was read by the camera RowCorrection(row) * cam.
  mp.position = RollingShutter()
                    ? world_from_cam * (RowCorrection(frame.features.keypoints[i].pt.y).Inverse() * in_cam)
                    : world_from_cam * in_cam;
  mp.in_cam = in_cam;
  mp.row = frame.features.keypoints[i].pt.y;
  mp.descriptor = frame.descriptors[i];
  const int level = frame.features.keypoints[i].octave;
  const double distance = in_cam.norm();
  mp.max_distance = distance * level_scale[level];
  mp.min_distance = mp.max_distance / level_scale.back();
  mp.visible_stamp = frame_counter;
  return mp;
}

long OrbTracker::Impl::AddPoint(const CurrentFrame& frame, int i, const Rigid3d& world_from_cam, int kf) {
  MapPoint mp = MakePoint(frame, i, world_from_cam);
  mp.keyframes.push_back(kf);
  mp.features.push_back(i);
  ++live_points;
  return map.NewPoint(std::move(mp));
}

void OrbTracker::Impl::MakeLastFrameVoPoints(const CurrentFrame& frame, const Rigid3d& cam_from_world) {
  last_frame_vo.clear();
  last_frame_vo_angles.clear();
  if (options.last_frame_points <= 0) return;
  std::vector<int> candidates;
  for (size_t i = 0; i < frame.size(); ++i) {
    if (frame.depth[i] <= 0.0f || (frame.map_points[i] >= 0 && frame.inlier[i])) continue;
    if (frame.features.weights[i] < options.min_point_weight) continue;
    candidates.push_back(static_cast<int>(i));
  }
  const size_t n = std::min(candidates.size(), static_cast<size_t>(options.last_frame_points));
  std::partial_sort(candidates.begin(), candidates.begin() + n, candidates.end(),
                    [&](int a, int b) { return frame.depth[a] < frame.depth[b] || (frame.depth[a] == frame.depth[b] && a < b); });
  const Rigid3d world_from_cam = cam_from_world.Inverse();
  for (size_t k = 0; k < n; ++k) {
    last_frame_vo.push_back(MakePoint(frame, candidates[k], world_from_cam));
    last_frame_vo_angles.push_back(frame.features.keypoints[candidates[k]].angle);
  }
}

void OrbTracker::Impl::CreateKeyframe(CurrentFrame* frame, const Rigid3d& pose, const cv::Mat& gray) {
  const int kf_index = static_cast<int>(keyframes.size());
  Keyframe kf;
  kf.timestamp = frame->timestamp;
  kf.cam_from_world = pose;
  if (RollingShutter()) kf.twist = frame_twist;
  kf.points = frame->features.points;
  kf.descriptors = frame->descriptors;
  kf.depths = frame->depth;
  kf.weights = frame->features.weights;
  kf.angles.resize(frame->size());
  kf.rows.resize(frame->size());
  kf.levels.resize(frame->size());
  for (size_t i = 0; i < frame->size(); ++i) {
    const cv::KeyPoint& kp = frame->features.keypoints[i];
    kf.angles[i] = kp.angle;
    kf.rows[i] = kp.pt.y;
    kf.levels[i] = kp.octave;
  }
  kf.map_points.assign(frame->size(), -1);
  kf.thumbnail = Thumbnail(gray);
  // Tracked points gain an observation.
  for (size_t i = 0; i < frame->size(); ++i) {
    const long id = frame->map_points[i];
    if (id < 0 || !frame->inlier[i]) continue;
    kf.map_points[i] = id;
    points[id].keyframes.push_back(kf_index);
    points[id].features.push_back(static_cast<int>(i));
  }
  // New points from depth: all near ones, then the nearest far ones up to min_new_points.
  std::vector<int> fresh;
  for (size_t i = 0; i < frame->size(); ++i)
    if (kf.map_points[i] < 0 && frame->depth[i] > 0.0f && frame->features.weights[i] >= options.min_point_weight)
      fresh.push_back(static_cast<int>(i));
  std::sort(fresh.begin(), fresh.end(), [&](int a, int b) {
    return frame->depth[a] != frame->depth[b] ? frame->depth[a] < frame->depth[b] : a < b;
  });
  const Rigid3d world_from_cam = pose.Inverse();
  int created = 0;
  for (int i : fresh) {
    if (frame->depth[i] > options.close_depth && created >= options.min_new_points) break;
    const long id = AddPoint(*frame, i, world_from_cam, kf_index);
    kf.map_points[i] = id;
    frame->map_points[i] = id;
    frame->inlier[i] = 1;
    ++created;
  }
  keyframes.push_back(std::move(kf));
  ++map.live_keyframes;
  keyframe_without_motion = (options.rolling_shutter_readout > 0.0 && !RollingShutter()) ? kf_index : -1;
  reference_keyframe = kf_index;
  frames_since_keyframe = 0;
  AddToPlaceDatabase(kf_index);
}

void OrbTracker::Impl::ReplacePointsForRollingShutter(int kf_index, const Vector6d& twist) {
  const Vector6d saved = frame_twist;
  frame_twist = twist;
  keyframes[kf_index].twist = twist;
  const Rigid3d world_from_cam = keyframes[kf_index].cam_from_world.Inverse();
  for (long id : keyframes[kf_index].map_points) {
    if (id < 0) continue;
    MapPoint& mp = points[id];
    if (mp.keyframes.empty() || mp.keyframes.front() != kf_index) continue;  // made by an earlier keyframe
    mp.position = world_from_cam * (RowCorrection(mp.row).Inverse() * mp.in_cam);
  }
  frame_twist = saved;
}

void OrbTracker::Impl::CullPoints() {
  for (MapPoint& mp : points) {
    if (mp.bad || mp.visible < options.cull_min_visible) continue;
    if (mp.found < options.cull_min_found_ratio * mp.visible) {
      mp.bad = true;
      --live_points;
    }
  }
}

Rigid3d OrbTracker::Impl::Predict(double timestamp) const {
  if (!has_motion) return last_pose;
  const double dt = timestamp - last_timestamp;
  double ratio = 1.0;
  if (last_dt > 0.0 && dt > 0.0) ratio = std::min(dt / last_dt, 4.0);
  const Vector6d twist = last_delta.Log() * ratio;
  return Rigid3d::Exp(twist) * last_pose;
}

void OrbTracker::Impl::AddToPlaceDatabase(int kf) {
  if (!vocabulary) {
    if (map.live_keyframes < options.vocabulary_train_keyframes) return;
    std::vector<std::vector<Descriptor>> images;
    for (const Keyframe& k : keyframes)
      if (!k.bad) images.push_back(k.descriptors);
    vocabulary = std::make_unique<Vocabulary>(Vocabulary::Train(images, options.vocabulary));
    DYPHO_LOG(Debug) << "vocabulary trained at start-up from " << images.size() << " keyframes: "
                     << vocabulary->num_words() << " words";
    for (size_t k = 0; k < keyframes.size(); ++k)
      if (!keyframes[k].bad) bow.Add(static_cast<int>(k), vocabulary->Transform(keyframes[k].descriptors));
    return;
  }
  bow.Add(kf, vocabulary->Transform(keyframes[kf].descriptors));
}

void OrbTracker::Impl::RunBackend(int kf) {
  if (!options.local_ba.enabled) return;
  if (local_ba_worker) {
    // Threaded: a snapshot to the worker, unless it is still busy.
    if (options.local_ba.fixed_lag > 0 ? local_ba_submitted >= 0 : local_ba_worker->Busy()) {
      ++backend.local_ba_skipped;
      return;
    }
    local_ba_submitted = frame_counter;
    local_ba_worker->Submit(BuildLocalBaProblem(map, kf, options.local_ba, camera, options.extractor.scale_factor,
                                                options.rolling_shutter_readout));
    return;
  }
  const LocalBaProblem problem =
      BuildLocalBaProblem(map, kf, options.local_ba, camera, options.extractor.scale_factor,
                          options.rolling_shutter_readout);
  FinishLocalBa(SolveLocalBa(camera, problem, options.local_ba, options.optimizer));
}

void OrbTracker::Impl::CollectBackend(bool wait) {
  if (!local_ba_worker) return;
  if (options.local_ba.fixed_lag > 0 && !wait) {
    // Fixed lag: the solution in flight is applied at its frame + lag exactly.
    if (local_ba_submitted < 0 || frame_counter - local_ba_submitted < options.local_ba.fixed_lag) return;
    wait = true;
  }
  std::optional<LocalBaSolution> solution = wait ? local_ba_worker->WaitAndTake() : local_ba_worker->Take();
  local_ba_submitted = -1;
  if (solution) FinishLocalBa(*solution);
}

void OrbTracker::Impl::FinishLocalBa(const LocalBaSolution& solution) {
  if (!solution.usable) {
    ++backend.local_ba_skipped;
    return;
  }
  const LocalBaApplied applied = ApplyLocalBa(solution, &map);
  ++backend.local_ba_runs;
  backend.local_ba_ms += solution.solve_ms;
  backend.local_ba_max_ms = std::max(backend.local_ba_max_ms, solution.solve_ms);
  backend.erased_observations += applied.erased;
  DYPHO_LOG(Debug) << "local BA of keyframe " << solution.problem.keyframe << ": "
                   << solution.problem.num_free_keyframes() << " free keyframes of "
                   << solution.problem.keyframes.size() << ", " << solution.problem.points.size() << " points, "
                   << solution.problem.observations.size() << " observations, cost " << solution.initial_cost
                   << " -> " << solution.final_cost << ", " << applied.erased << " outliers erased, "
                   << solution.solve_ms << " ms";
  if (options.local_ba.cull_keyframes) {
    std::vector<int> candidates;
    for (size_t i = 0; i < solution.problem.keyframes.size(); ++i)
      if (!solution.problem.fixed[i]) candidates.push_back(solution.problem.keyframes[i]);
    const std::vector<int> culled = CullRedundantKeyframes(candidates, options.keyframe_culling, &map);
    backend.culled_keyframes += static_cast<int>(culled.size());
    for (int kf : culled) {
      bow.Erase(kf);
      DYPHO_LOG(Debug) << "keyframe " << kf << " culled as redundant";
    }
  }
  // The reference keyframe may have been culled: the newest keyframe is never.
  if (reference_keyframe >= 0 && keyframes[reference_keyframe].bad)
    reference_keyframe = static_cast<int>(keyframes.size()) - 1;
  ForgetBadLastPoints();
}

void OrbTracker::Impl::ReleasePoints() {
  if (released_at_keyframes == keyframes.size()) return;  // nothing culled since
  // A snapshot in flight names points by id: wait until none is.
  if (local_ba_worker && (local_ba_submitted >= 0 || local_ba_worker->Busy())) return;
  if (loop_worker && loop_worker->InFlight() > 0) return;
  ForgetBadLastPoints();
  backend.released_points += map.ReleaseBadPoints();
  released_at_keyframes = keyframes.size();
}

// The last frame's points that lost their last observation (culled or fused).
void OrbTracker::Impl::ForgetBadLastPoints() {
  for (size_t j = 0; j < last_points.size();) {
    if (points[last_points[j]].bad) {
      last_points.erase(last_points.begin() + j);
      last_angles.erase(last_angles.begin() + j);
    } else {
      ++j;
    }
  }
}

LocalBaProblem OrbTracker::LocalBaWindow(int kf) const {
  DYPHO_CHECK_INPUT(kf >= 0 && kf < static_cast<int>(impl_->keyframes.size()) && !impl_->keyframes[kf].bad)
      << "LocalBaWindow: keyframe " << kf << " is unknown or culled (" << impl_->keyframes.size() << " keyframes)";
  const Impl& m = *impl_;
  return BuildLocalBaProblem(m.map, kf, m.options.local_ba, m.camera, m.options.extractor.scale_factor,
                             m.options.rolling_shutter_readout);
}

}  // namespace dypho
