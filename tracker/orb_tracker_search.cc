#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "tracker/orb_tracker_impl.h"

namespace dypho {

using namespace orb_internal;

float OrbTracker::Impl::ReadDepth(const cv::Mat& depth, const cv::Point2f& p) const {
  if (depth.empty()) return 0.0f;
  const int x = cvRound(p.x), y = cvRound(p.y);
  if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows) return 0.0f;
  const float z = depth.at<float>(y, x);
  if (!std::isfinite(z) || z < options.min_depth || z > options.max_depth) return 0.0f;
  float lo = z, hi = z;
  for (int dy = -1; dy <= 1; ++dy) {
    const int yy = y + dy;
    if (yy < 0 || yy >= depth.rows) continue;
    const float* row = depth.ptr<float>(yy);
    for (int dx = -1; dx <= 1; ++dx) {
      const int xx = x + dx;
      if (xx < 0 || xx >= depth.cols) continue;
      const float v = row[xx];
      if (!std::isfinite(v) || v <= 0.0f) continue;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (hi - lo > options.max_depth_spread * z) return 0.0f;
  return z;
}

CurrentFrame OrbTracker::Impl::BuildFrame(const TrackerFrame& in, const cv::Mat& gray, const OrbPrepared* prepared) {
  CurrentFrame frame;
  frame.timestamp = in.timestamp;
  frame.features = extractor.Extract(gray, in.dynamic_mask, in.static_weight, &extraction_stats, prepared);
  frame.descriptors = DescriptorsFromMat(frame.features.descriptors);
  const size_t n = frame.features.size();
  frame.depth.resize(n);
  if (in.depth.empty() && !in.right_image.empty() && options.stereo.baseline > 0.0) {
    // Stereo: the features' depth from the right image, in the depth range.
    cv::Mat right = in.right_image;
    if (right.channels() == 3) cv::cvtColor(in.right_image, right, cv::COLOR_RGB2GRAY);
    if (!in.stereo_prior_depth.empty()) {
      frame.depth = StereoFeatureDepthsFromPrior(frame.features, in.stereo_prior_depth, gray, right, camera.fx,
                                                 options.stereo, &stereo_stats);
    } else {
      const OrbFeatures right_features = right_extractor.Extract(right);
      frame.depth = StereoFeatureDepths(frame.features, right_features, gray, right, camera.fx,
                                        options.extractor.scale_factor, options.stereo, &stereo_stats);
    }
    for (float& d : frame.depth)
      if (d < options.min_depth || d > options.max_depth) d = 0.0f;
  } else {
    for (size_t i = 0; i < n; ++i) frame.depth[i] = ReadDepth(in.depth, frame.features.keypoints[i].pt);
  }
  for (size_t i = 0; i < n; ++i) frame.with_depth += frame.depth[i] > 0.0f;
  frame.map_points.assign(n, -1);
  frame.match_distance.assign(n, 256);
  frame.inlier.assign(n, 0);
  frame.grid.Build(frame.features.points, camera.width, camera.height, 10);
  return frame;
}

int OrbTracker::Impl::PredictLevel(const MapPoint& mp, double distance) const {
  const double ratio = mp.max_distance / distance;
  const int level = static_cast<int>(std::ceil(std::log(ratio) / log_scale));
  return std::clamp(level, 0, static_cast<int>(level_scale.size()) - 1);
}

void OrbTracker::Impl::MarkVisible(long id) {
  MapPoint& mp = points[id];
  if (mp.visible_stamp == frame_counter) return;
  mp.visible_stamp = frame_counter;
  ++mp.visible;
}

int OrbTracker::Impl::SearchByProjection(CurrentFrame* frame, const Rigid3d& pose, const std::vector<long>& ids,
                                         const std::vector<float>* ref_angles, double radius,
                                         bool count_visible) {
  const Eigen::Matrix3d R = pose.rotation.toRotationMatrix();
  std::vector<int> candidates;
  std::vector<int> matched_features;
  std::vector<float> angle_diffs;
  for (size_t k = 0; k < ids.size(); ++k) {
    const long id = ids[k];
    if (id < 0) continue;
    const MapPoint& mp = points[id];
    if (mp.bad || mp.matched_stamp == match_stamp) continue;
    Eigen::Vector3d p = R * mp.position + pose.translation;
    if (p.z() <= 0.05) continue;
    double u = camera.fx * p.x() / p.z() + camera.cx;
    double v = camera.fy * p.y() / p.z() + camera.cy;
    if (RollingShutter()) {
      p = RowCorrection(v) * p;
      if (p.z() <= 0.05) continue;
      u = camera.fx * p.x() / p.z() + camera.cx;
      v = camera.fy * p.y() / p.z() + camera.cy;
    }
    if (u < 0.0 || v < 0.0 || u > camera.width - 1 || v > camera.height - 1) continue;
    const double distance = p.norm();
    if (distance < 0.8 * mp.min_distance || distance > 1.2 * mp.max_distance) continue;
    if (count_visible) MarkVisible(id);
    const int predicted = PredictLevel(mp, distance);
    frame->grid.Query(static_cast<float>(u), static_cast<float>(v),
                      static_cast<float>(radius * level_scale[predicted]), &candidates);
    int best = 257, second = 257, best_index = -1, best_level = -1, second_level = -1;
    for (int f : candidates) {
      const int level = frame->features.keypoints[f].octave;
      if (level < predicted - 1 || level > predicted + 1) continue;
      if (frame->inlier[f]) continue;  // taken by an earlier stage
      const int d = HammingDistance(mp.descriptor, frame->descriptors[f]);
      if (d < best) {
        second = best;
        second_level = best_level;
        best = d;
        best_index = f;
        best_level = level;
      } else if (d < second) {
        second = d;
        second_level = level;
      }
    }
    if (best_index < 0 || best > options.max_projection_distance) continue;
    if (best_level == second_level && best > options.match_ratio * second) continue;
    if (frame->map_points[best_index] >= 0 && frame->match_distance[best_index] <= best) continue;
    frame->map_points[best_index] = id;
    frame->match_distance[best_index] = best;
    if (ref_angles != nullptr) {
      matched_features.push_back(best_index);
      angle_diffs.push_back((*ref_angles)[k] - frame->features.keypoints[best_index].angle);
    }
  }
  if (ref_angles != nullptr && !matched_features.empty()) {
    const std::vector<char> keep = RotationConsistent(angle_diffs);
    for (size_t j = 0; j < matched_features.size(); ++j)
      if (!keep[j]) frame->map_points[matched_features[j]] = -1;
  }
  return frame->NumMatches();
}

PoseOptimizerResult OrbTracker::Impl::Optimize(CurrentFrame* frame, const Rigid3d& initial) {
  std::vector<PoseObservation> observations;
  std::vector<int> feature_of;
  for (size_t i = 0; i < frame->size(); ++i) {
    const long id = frame->map_points[i];
    if (id < 0) continue;
    PoseObservation o;
    o.point_world = points[id].position;
    const cv::Point2f& px = frame->features.points[i];
    o.pixel = Eigen::Vector2d(px.x, px.y);
    o.depth = frame->depth[i];
    o.sigma = level_scale[frame->features.keypoints[i].octave];
    o.weight = frame->features.weights[i];
    if (RollingShutter()) o.row_cam_from_cam = RowCorrection(frame->features.keypoints[i].pt.y);
    observations.push_back(o);
    feature_of.push_back(static_cast<int>(i));
  }
  PoseOptimizerResult result = OptimizePose(camera, observations, initial, options.optimizer);
  std::fill(frame->inlier.begin(), frame->inlier.end(), 0);
  for (size_t j = 0; j < feature_of.size(); ++j) {
    const int i = feature_of[j];
    if (result.inliers[j]) {
      frame->inlier[i] = 1;
    } else {
      frame->map_points[i] = -1;  // free the feature for other points
    }
  }
  // Only the features whose weight is not zero really support the pose.
  int supported = 0;
  for (size_t j = 0; j < feature_of.size(); ++j)
    supported += result.inliers[j] && observations[j].weight > 0.0;
  result.num_inliers = supported;
  return result;
}

std::vector<long> OrbTracker::Impl::LocalMap(const CurrentFrame& frame) {
  std::vector<int> counts(keyframes.size(), 0);
  for (size_t i = 0; i < frame.size(); ++i) {
    const long id = frame.map_points[i];
    if (id < 0 || !frame.inlier[i]) continue;
    for (int kf : points[id].keyframes) ++counts[kf];
  }
  std::vector<int> order;
  for (size_t k = 0; k < counts.size(); ++k)
    if (counts[k] > 0) order.push_back(static_cast<int>(k));
  std::sort(order.begin(), order.end(), [&](int a, int b) { return counts[a] != counts[b] ? counts[a] > counts[b] : a > b; });
  if (!order.empty()) reference_keyframe = order.front();
  if (static_cast<int>(order.size()) > options.local_keyframes) order.resize(options.local_keyframes);
  for (int r = 0; r < options.recent_keyframes; ++r) {
    const int kf = static_cast<int>(keyframes.size()) - 1 - r;
    if (kf >= 0 && !keyframes[kf].bad && std::find(order.begin(), order.end(), kf) == order.end())
      order.push_back(kf);
  }
  if (reference_keyframe >= 0 && std::find(order.begin(), order.end(), reference_keyframe) == order.end())
    order.push_back(reference_keyframe);
  ++local_stamp;
  std::vector<long> ids;
  for (int kf : order) {
    for (long id : keyframes[kf].map_points) {
      if (id < 0) continue;
      MapPoint& mp = points[id];
      if (mp.bad || mp.local_stamp == local_stamp || mp.matched_stamp == match_stamp) continue;
      mp.local_stamp = local_stamp;
      ids.push_back(id);
    }
  }
  return ids;
}

int OrbTracker::Impl::MatchKeyframe(CurrentFrame* frame, int kf_index) {
  const Keyframe& kf = keyframes[kf_index];
  std::vector<char> usable(kf.map_points.size(), 0);
  for (size_t i = 0; i < kf.map_points.size(); ++i) {
    const long id = kf.map_points[i];
    usable[i] = id >= 0 && !points[id].bad;
  }
  const std::vector<DescriptorMatch> matches = MatchBruteForce(
      frame->descriptors, kf.descriptors, options.max_keyframe_distance, options.keyframe_match_ratio, &usable);
  std::vector<float> diffs;
  for (const DescriptorMatch& m : matches) diffs.push_back(kf.angles[m.train] - frame->features.keypoints[m.query].angle);
  const std::vector<char> keep = RotationConsistent(diffs);
  frame->ClearMatches();
  int n = 0;
  for (size_t j = 0; j < matches.size(); ++j) {
    if (!keep[j]) continue;
    frame->map_points[matches[j].query] = kf.map_points[matches[j].train];
    frame->match_distance[matches[j].query] = matches[j].distance;
    ++n;
  }
  return n;
}

// The fine stage: search the local map around `*pose` (whose inlier matches
// are in `frame`), then optimise with every match.
bool OrbTracker::Impl::TrackLocalMap(CurrentFrame* frame, Rigid3d* pose, double radius, int min_inliers,
                                     PoseOptimizerResult* result) {
  // The points matched so far are not searched again.
  ++match_stamp;
  for (size_t i = 0; i < frame->size(); ++i)
    if (frame->map_points[i] >= 0 && frame->inlier[i]) points[frame->map_points[i]].matched_stamp = match_stamp;
  const std::vector<long> local = LocalMap(*frame);
  SearchByProjection(frame, *pose, local, nullptr, radius, /*count_visible=*/true);
  std::fill(frame->inlier.begin(), frame->inlier.end(), 0);
  *result = Optimize(frame, *pose);
  if (!result->usable || result->num_inliers < min_inliers) return false;
  *pose = result->cam_from_world;
  return true;
}

}  // namespace dypho
