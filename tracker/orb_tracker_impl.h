// Internals of the ORB tracker (tracker/orb_tracker.h), shared by its source
// files: orb_tracker.cc (options, the per-frame steps), orb_tracker_search.cc
// (features, matching, pose optimisation), orb_tracker_map.cc (keyframes,
// points, relocalisation, the back end). Not a public header.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "tracker/backend/bow_database.h"
#include "tracker/backend/local_ba_worker.h"
#include "tracker/backend/loop_detection.h"
#include "tracker/backend/loop_worker.h"
#include "tracker/backend/vocabulary.h"
#include "tracker/backend/sparse_map.h"
#include "tracker/orb_matcher.h"
#include "tracker/orb_tracker.h"

namespace dypho {
namespace orb_internal {

using Clock = std::chrono::steady_clock;
using Vector6d = Eigen::Matrix<double, 6, 1>;

inline double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

constexpr int kThumbWidth = 40;
constexpr int kThumbHeight = 30;
constexpr int kCoverageCols = 8;
constexpr int kCoverageRows = 6;
constexpr int kMinRelocalisationMatches = 15;  // descriptor matches needed to try PnP on a keyframe

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

// OrbTracker's TrackerPrepared: the grey image and the extractor's prepared
// levels of the image at `source` (the pixels PrepareJob was given).
struct OrbTrackerPrepared : TrackerPrepared {
  const uint8_t* source = nullptr;
  std::shared_ptr<const OrbPrepared> orb;
};

// [30, 40] CV_32F thumbnail, zero mean, unit norm (zero for a flat image).
cv::Mat Thumbnail(const cv::Mat& gray);

}  // namespace orb_internal

struct OrbTracker::Impl {
  using CurrentFrame = orb_internal::CurrentFrame;
  using Vector6d = orb_internal::Vector6d;

  Impl(const Camera& cam, const OrbTrackerOptions& opts)
      : camera(cam), options(opts), extractor(opts.extractor, cam), right_extractor(opts.extractor, cam),
        loop_detector(opts.loops) {
    const int levels = opts.extractor.num_levels;
    for (int l = 0; l < levels; ++l) level_scale.push_back(extractor.LevelScale(l));
    log_scale = std::log(opts.extractor.scale_factor);
    camera_matrix = (cv::Mat_<double>(3, 3) << cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  }

  Camera camera;
  OrbTrackerOptions options;
  OrbExtractor extractor;
  OrbExtractor right_extractor;  // the right image of a stereo frame (options.stereo)
  StereoFeatureStats stereo_stats;  // of the last stereo frame
  OrbExtractionStats extraction_stats;  // of the last frame (left image)
  LoopDetector loop_detector;  // step 9 (keeps the candidate groups between keyframes)
  std::vector<double> level_scale;
  double log_scale = 0.0;
  cv::Mat camera_matrix;
  cv::Mat gray_buffer;

  // The map (points, keyframes and live_points name its parts).
  SparseMap map;
  std::vector<MapPoint>& points = map.points;
  std::vector<Keyframe>& keyframes = map.keyframes;
  int& live_points = map.live_points;

  // The back end: local BA on its own thread (options.local_ba.threaded).
  std::unique_ptr<LocalBaWorker> local_ba_worker;
  // ... and loop detection and closure (options.loops.threaded).
  std::unique_ptr<LoopWorker> loop_worker;
  long loop_applied_frame = -1;  // frame_counter when the last threaded closure was applied
  size_t released_at_keyframes = 0;  // keyframes.size() at the last ReleasePoints
  OrbBackendStats backend;

  // Place recognition: the vocabulary (from the file, or trained at
  // start-up) and the keyframes' bag-of-words vectors.
  std::unique_ptr<Vocabulary> vocabulary;
  bool vocabulary_from_file = false;
  BowDatabase bow;

  // Tracking state.
  bool initialized = false;
  bool lost = false;
  long frame_counter = 0;
  long local_ba_submitted = -1;  // threaded, fixed lag: frame_counter when the solve in flight was submitted
  long local_stamp = 0;  // one per local-map build
  long match_stamp = 0;  // one per frame and per local-map search (TrackLocalMap)
  CoarseSource source = CoarseSource::kNone;  // this frame's first pose estimate (diagnostics)
  int source_matches = 0;
  Rigid3d last_pose;
  double last_timestamp = 0.0;
  bool has_motion = false;
  bool motion_before_loss = false;  // has_motion when tracking was lost (PredictOverLoss)
  int lost_frames = 0;              // frames since the loss that failed to relocalise
  Rigid3d last_delta;     // cam_from_world(k) * cam_from_world(k-1)^-1
  double last_dt = 0.0;   // [s] time between the frames of last_delta
  std::vector<long> last_points;   // inlier map points of the last tracked frame
  std::vector<float> last_angles;  // their keypoint angles [deg]
  // Temporary points of the last frame for the coarse stage (options.last_frame_points).
  std::vector<MapPoint> last_frame_vo;
  std::vector<float> last_frame_vo_angles;
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
  // The pose at `timestamp` after a loss: the motion from before it (last_delta
  // over last_dt) carried on over the whole gap, else the last pose.
  Rigid3d PredictOverLoss(double timestamp) const {
    const double gap = timestamp - last_timestamp;
    if (!motion_before_loss || !(last_dt > 0.0) || !(gap > 0.0)) return last_pose;
    return Rigid3d::Exp(last_delta.Log() * (gap / last_dt)) * last_pose;
  }
  bool RollingShutter() const { return options.rolling_shutter_readout > 0.0 && !frame_twist.isZero(); }

  void Clear() {
    if (local_ba_worker) local_ba_worker->WaitAndTake();  // a solution for the old map is dropped
    local_ba_submitted = -1;
    DropLoopJobs();
    map.Clear();
    released_at_keyframes = 0;
    bow = BowDatabase();
    loop_detector.Reset();
    if (!vocabulary_from_file) vocabulary.reset();
    backend = OrbBackendStats();
    initialized = false;
    lost = false;
    has_motion = false;
    motion_before_loss = false;
    lost_frames = 0;
    last_points.clear();
    last_angles.clear();
    last_frame_vo.clear();
    last_frame_vo_angles.clear();
    reference_keyframe = -1;
    frames_since_keyframe = 0;
    keyframe_without_motion = -1;
    frame_twist.setZero();
    last_pose = Rigid3d();
  }

  float ReadDepth(const cv::Mat& depth, const cv::Point2f& p) const;
  // `prepared` (optional): the extractor's work made ahead for `gray`.
  CurrentFrame BuildFrame(const TrackerFrame& in, const cv::Mat& gray, const OrbPrepared* prepared);
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
  void ForgetBadLastPoints();  // drops culled/fused points from last_points (and last_angles)
  // Between frames, when no back-end snapshot is in flight and a keyframe
  // was made since the last time: the bad points' slots are released for
  // new points (SparseMap::ReleaseBadPoints), so the map stays bounded.
  void ReleasePoints();
  void ReplacePointsForRollingShutter(int kf_index, const Vector6d& twist);
  long AddPoint(const CurrentFrame& frame, int i, const Rigid3d& world_from_cam, int kf);
  // A point from feature i of a frame at `world_from_cam` (AddPoint without the map).
  MapPoint MakePoint(const CurrentFrame& frame, int i, const Rigid3d& world_from_cam) const;
  // The last frame's temporary points: its features with depth and static
  // weight that are not map-point inliers, nearest first.
  void MakeLastFrameVoPoints(const CurrentFrame& frame, const Rigid3d& cam_from_world);
  Rigid3d Predict(double timestamp) const;
  // Back end, after keyframe `kf` was made: local BA (solved now, or handed
  // to the worker), then culling of redundant keyframes.
  void RunBackend(int kf);
  // Threaded mode: applies a finished solution (with `wait`, waits for it).
  void CollectBackend(bool wait);
  void FinishLocalBa(const LocalBaSolution& solution);
  // After keyframe `kf` was made: its bag of words into the database; trains
  // the start-up vocabulary once enough keyframes exist.
  void AddToPlaceDatabase(int kf);
  // Step 9 after keyframe `kf` was made (tracker/orb_tracker_loops.cc):
  // detects a loop and closes it; *pose (the keyframe's) is corrected.
  // Returns whether a loop was closed.
  bool CloseLoops(int kf, Rigid3d* pose);
  // Step 9 on its parts (orb_tracker_loops.cc). The closure of a detected
  // loop on `map` (the live map, or the worker's snapshot).
  void CloseDetectedLoop(LoopOutcome* o, SparseMap* map, bool record_motion) const;
  // The worker's job (on the worker's thread: reads only camera and options).
  LoopOutcome ProcessLoopJob(LoopDetector* detector, LoopJob job) const;
  void NoteLoopQuery(const LoopOutcome& o);  // query statistics
  void RecordLoop(const LoopOutcome& o);     // a closure: statistics, record, log
  // Threaded: snapshot for the worker; outcomes due (fixed lag) or ready
  // applied (all with `wait_all`); returns whether a loop was closed.
  void SubmitLoopQuery(int kf);
  bool CollectLoops(bool wait_all);
  bool ApplyLoopOutcome(const LoopOutcome& o);
  void DropLoopJobs();  // a new map: outcomes for the old one dropped
  bool TrackFrame(CurrentFrame* frame, const cv::Mat& gray, Rigid3d* pose, PoseOptimizerResult* optimized,
                  bool* relocalized, std::string* why);
  // Returns whether the frame became a keyframe.
  // *pose may change: a loop closure corrects it.
  bool UpdateMap(CurrentFrame* frame, const cv::Mat& gray, Rigid3d* pose, bool relocalized, int inliers,
                 bool* loop_closed);
};

}  // namespace dypho
