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

namespace dypho {
namespace {

using Clock = std::chrono::steady_clock;
using Vector6d = Eigen::Matrix<double, 6, 1>;

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

constexpr int kThumbWidth = 40;
constexpr int kThumbHeight = 30;
constexpr int kCoverageCols = 8;
constexpr int kCoverageRows = 6;
constexpr int kMinRelocalisationMatches = 15;  // descriptor matches needed to try PnP on a keyframe

struct MapPoint {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world [m]
  Descriptor descriptor{};
  double max_distance = 0.0;  // [m] farthest distance at which the point is detectable at level 0
  double min_distance = 0.0;  // [m] nearest distance (at the top level)
  int visible = 1;            // frames in which it was predicted in view
  int found = 1;              // frames in which it was matched as an inlier
  std::vector<int> keyframes; // keyframes observing it (the first one created it)
  Eigen::Vector3d in_cam = Eigen::Vector3d::Zero();  // [m] where its keyframe saw it (its own camera)
  float row = 0.0f;           // image row of that observation (rolling shutter)
  long visible_stamp = -1;    // last frame counted in `visible`
  long matched_stamp = -1;    // last local-map search in which it was already matched
  long local_stamp = -1;      // last local-map build that took it
  bool bad = false;
};

struct Keyframe {
  double timestamp = 0.0;
  Rigid3d cam_from_world;
  std::vector<cv::Point2f> points;  // undistorted [px]
  std::vector<float> angles;        // [deg]
  std::vector<Descriptor> descriptors;
  std::vector<long> map_points;     // per feature, -1 = none
  cv::Mat thumbnail;                // [30, 40] CV_32F, zero mean, unit norm (zero for a flat image)
};

// The frame being tracked.
struct CurrentFrame {
  double timestamp = 0.0;
  OrbFeatures features;
  std::vector<Descriptor> descriptors;
  std::vector<float> depth;          // per feature [m], 0 = none
  std::vector<long> map_points;      // per feature, -1 = none
  std::vector<int> match_distance;   // per feature, Hamming distance of its match
  std::vector<char> inlier;          // per feature, after the last optimisation
  FeatureGrid grid;
  int with_depth = 0;

  size_t size() const { return features.size(); }
  void ClearMatches() {
    std::fill(map_points.begin(), map_points.end(), -1);
    std::fill(inlier.begin(), inlier.end(), 0);
  }
  int NumMatches() const {
    return static_cast<int>(std::count_if(map_points.begin(), map_points.end(), [](long id) { return id >= 0; }));
  }
};

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

}  // namespace

bool OrbTrackerOptions::IsValid(std::string* error) const {
  if (!extractor.IsValid(error)) {
    if (error != nullptr) *error = "OrbTrackerOptions.extractor: " + *error;
    return false;
  }
  if (!optimizer.IsValid(error)) {
    if (error != nullptr) *error = "OrbTrackerOptions.optimizer: " + *error;
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
  } else if (min_inliers < 6) {
    e << "min_inliers must be >= 6 (got " << min_inliers << ")";
  } else if (relocalisation_min_inliers < 6) {
    e << "relocalisation_min_inliers must be >= 6 (got " << relocalisation_min_inliers << ")";
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

struct OrbTracker::Impl {
  Impl(const Camera& cam, const OrbTrackerOptions& opts) : camera(cam), options(opts), extractor(opts.extractor, cam) {
    const int levels = opts.extractor.num_levels;
    for (int l = 0; l < levels; ++l) level_scale.push_back(extractor.LevelScale(l));
    log_scale = std::log(opts.extractor.scale_factor);
    camera_matrix = (cv::Mat_<double>(3, 3) << cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  }

  Camera camera;
  OrbTrackerOptions options;
  OrbExtractor extractor;
  std::vector<double> level_scale;
  double log_scale = 0.0;
  cv::Mat camera_matrix;
  cv::Mat gray_buffer;

  // The map.
  std::vector<MapPoint> points;
  std::vector<Keyframe> keyframes;
  int live_points = 0;

  // Tracking state.
  bool initialized = false;
  bool lost = false;
  long frame_counter = 0;
  long local_stamp = 0;  // one per local-map build
  long match_stamp = 0;  // one per frame and per local-map search (TrackLocalMap)
  CoarseSource source = CoarseSource::kNone;  // this frame's first pose estimate (diagnostics)
  int source_matches = 0;
  Rigid3d last_pose;
  double last_timestamp = 0.0;
  bool has_motion = false;
  Rigid3d last_delta;     // cam_from_world(k) * cam_from_world(k-1)^-1
  double last_dt = 0.0;   // [s] time between the frames of last_delta
  std::vector<long> last_points;   // inlier map points of the last tracked frame
  std::vector<float> last_angles;  // their keypoint angles [deg]
  int reference_keyframe = -1;
  long frames_since_keyframe = 0;
  Vector6d frame_twist = Vector6d::Zero();  // [1/s] motion of the current frame (rolling shutter)
  // A keyframe made while the motion was unknown (the first one, or right
  // after relocalisation): its points are placed again for the rolling
  // shutter once the next frame gives the motion.
  int keyframe_without_motion = -1;

  // The camera when image row `row` was read, from the camera at the frame's
  // reference time (the middle row), with the frame's constant velocity.
  Rigid3d RowCorrection(double row) const {
    if (options.rolling_shutter_readout <= 0.0) return Rigid3d();
    const double tau = options.rolling_shutter_readout * (row / std::max(1, camera.height - 1) - 0.5);
    return Rigid3d::Exp(frame_twist * tau);
  }
  bool RollingShutter() const { return options.rolling_shutter_readout > 0.0 && !frame_twist.isZero(); }

  void Clear() {
    points.clear();
    keyframes.clear();
    live_points = 0;
    initialized = false;
    lost = false;
    has_motion = false;
    last_points.clear();
    last_angles.clear();
    reference_keyframe = -1;
    frames_since_keyframe = 0;
    keyframe_without_motion = -1;
    frame_twist.setZero();
    last_pose = Rigid3d();
  }

  float ReadDepth(const cv::Mat& depth, const cv::Point2f& p) const;
  CurrentFrame BuildFrame(const TrackerFrame& in, const cv::Mat& gray);
  int PredictLevel(const MapPoint& mp, double distance) const;
  void MarkVisible(long id);
  int SearchByProjection(CurrentFrame* frame, const Rigid3d& pose, const std::vector<long>& ids,
                         const std::vector<float>* ref_angles, double radius, bool count_visible);
  PoseOptimizerResult Optimize(CurrentFrame* frame, const Rigid3d& initial);
  std::vector<long> LocalMap(const CurrentFrame& frame);
  int MatchKeyframe(CurrentFrame* frame, int kf);
  bool TrackLocalMap(CurrentFrame* frame, Rigid3d* pose, double radius, int min_inliers, PoseOptimizerResult* result);
  bool Relocalise(CurrentFrame* frame, const cv::Mat& gray, Rigid3d* pose, PoseOptimizerResult* result, std::string* why);
  // Why the frame should become a keyframe, or nullptr.
  const char* KeyframeReason(const CurrentFrame& frame, int inliers) const;
  void CreateKeyframe(CurrentFrame* frame, const Rigid3d& pose, const cv::Mat& gray);
  void CullPoints();
  void ReplacePointsForRollingShutter(int kf_index, const Vector6d& twist);
  long AddPoint(const CurrentFrame& frame, int i, const Rigid3d& world_from_cam, int kf);
  Rigid3d Predict(double timestamp) const;
  bool TrackFrame(CurrentFrame* frame, const cv::Mat& gray, Rigid3d* pose, PoseOptimizerResult* optimized,
                  bool* relocalized, std::string* why);
  // Returns whether the frame became a keyframe.
  bool UpdateMap(CurrentFrame* frame, const cv::Mat& gray, const Rigid3d& pose, bool relocalized, int inliers);
};

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

CurrentFrame OrbTracker::Impl::BuildFrame(const TrackerFrame& in, const cv::Mat& gray) {
  CurrentFrame frame;
  frame.timestamp = in.timestamp;
  frame.features = extractor.Extract(gray, in.dynamic_mask, in.static_weight);
  frame.descriptors = DescriptorsFromMat(frame.features.descriptors);
  const size_t n = frame.features.size();
  frame.depth.resize(n);
  for (size_t i = 0; i < n; ++i) {
    frame.depth[i] = ReadDepth(in.depth, frame.features.keypoints[i].pt);
    frame.with_depth += frame.depth[i] > 0.0f;
  }
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
    if (kf >= 0 && std::find(order.begin(), order.end(), kf) == order.end()) order.push_back(kf);
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

bool OrbTracker::Impl::Relocalise(CurrentFrame* frame, const cv::Mat& gray, Rigid3d* pose, PoseOptimizerResult* result,
                                  std::string* why) {
  if (keyframes.empty() || frame->size() < 10) {
    *why = "relocalisation: too few features (" + std::to_string(frame->size()) + ")";
    return false;
  }
  const cv::Mat thumb = Thumbnail(gray);
  std::vector<std::pair<double, int>> scores;
  for (size_t k = 0; k < keyframes.size(); ++k)
    scores.emplace_back(thumb.dot(keyframes[k].thumbnail), static_cast<int>(k));
  std::sort(scores.begin(), scores.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second > b.second;
  });
  std::vector<int> candidates;
  for (size_t k = 0; k < scores.size() && static_cast<int>(candidates.size()) < options.relocalisation_candidates; ++k)
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

long OrbTracker::Impl::AddPoint(const CurrentFrame& frame, int i, const Rigid3d& world_from_cam, int kf) {
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
  mp.keyframes.push_back(kf);
  mp.visible_stamp = frame_counter;
  points.push_back(std::move(mp));
  ++live_points;
  return static_cast<long>(points.size()) - 1;
}

void OrbTracker::Impl::CreateKeyframe(CurrentFrame* frame, const Rigid3d& pose, const cv::Mat& gray) {
  const int kf_index = static_cast<int>(keyframes.size());
  Keyframe kf;
  kf.timestamp = frame->timestamp;
  kf.cam_from_world = pose;
  kf.points = frame->features.points;
  kf.descriptors = frame->descriptors;
  kf.angles.resize(frame->size());
  for (size_t i = 0; i < frame->size(); ++i) kf.angles[i] = frame->features.keypoints[i].angle;
  kf.map_points.assign(frame->size(), -1);
  kf.thumbnail = Thumbnail(gray);
  // Tracked points gain an observation.
  for (size_t i = 0; i < frame->size(); ++i) {
    const long id = frame->map_points[i];
    if (id < 0 || !frame->inlier[i]) continue;
    kf.map_points[i] = id;
    points[id].keyframes.push_back(kf_index);
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
  keyframe_without_motion = (options.rolling_shutter_readout > 0.0 && !RollingShutter()) ? kf_index : -1;
  reference_keyframe = kf_index;
  frames_since_keyframe = 0;
}

void OrbTracker::Impl::ReplacePointsForRollingShutter(int kf_index, const Vector6d& twist) {
  const Vector6d saved = frame_twist;
  frame_twist = twist;
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

OrbTracker::OrbTracker(const Camera& camera, const OrbTrackerOptions& options) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << error;
  camera.Validate("OrbTracker camera");
  impl_ = std::make_unique<Impl>(camera, options);
}

OrbTracker::~OrbTracker() = default;

const OrbTrackerOptions& OrbTracker::options() const { return impl_->options; }
const Camera& OrbTracker::camera() const { return impl_->camera; }
int OrbTracker::num_keyframes() const { return static_cast<int>(impl_->keyframes.size()); }
int OrbTracker::num_map_points() const { return impl_->live_points; }

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
  for (double radius : {options.coarse_radius, options.wide_radius}) {
    if (!has_motion) break;
    frame->ClearMatches();
    std::fill(frame->match_distance.begin(), frame->match_distance.end(), 256);
    const int matches = SearchByProjection(frame, predicted, last_points, &last_angles, radius, false);
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
bool OrbTracker::Impl::UpdateMap(CurrentFrame* frame, const cv::Mat& gray, const Rigid3d& pose, bool relocalized,
                                 int inliers) {
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
  CreateKeyframe(frame, pose, gray);
  CullPoints();
  return true;
}

TrackResult OrbTracker::Track(const TrackerFrame& input) {
  Impl& m = *impl_;
  const auto t_start = Clock::now();
  TrackResult result;
  result.timestamp = input.timestamp;

  // 1. Check the input; grey image; features with depth and static weights.
  CheckTrackerFrame(input, m.camera);
  ++m.frame_counter;
  cv::Mat gray = input.image;
  if (input.image.channels() == 3) {
    cv::cvtColor(input.image, m.gray_buffer, cv::COLOR_RGB2GRAY);
    gray = m.gray_buffer;
  }
  CurrentFrame frame = m.BuildFrame(input, gray);
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
  } else {
    tracked = m.TrackFrame(&frame, gray, &pose, &optimized, &relocalized, &why);
  }
  const auto t_tracked = Clock::now();

  // 3. Motion model, map statistics, keyframe decision, culling.
  result.is_keyframe = started;
  if (tracked && !started) result.is_keyframe = m.UpdateMap(&frame, gray, pose, relocalized, optimized.num_inliers);
  if (m.initialized && !tracked) {
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
