// The thin ORB tracker for RGB-D streams: mask-aware ORB features
// (tracker/orb_extractor.h), frame-to-map matching and motion-only bundle
// adjustment (tracker/pose_optimizer.h) against a sparse map of points
// created from keyframe depth, refined by the back end (tracker/backend/):
// local bundle adjustment over covisible keyframes and culling of redundant
// keyframes after every keyframe (step 8), and loop closure (step 9).
//
// Per frame (OrbTracker::Track):
//  1. ORB features outside the dynamic mask, each with its depth reading
//     (none when the reading is missing, non-finite, outside
//     [min_depth, max_depth], or at a depth edge: its 3x3 neighbourhood
//     spans more than max_depth_spread of it) and its static weight.
//  2. No map yet: the first frame with min_init_features features with depth
//     becomes keyframe 0 at the identity pose (the world frame is the first
//     camera); its features with depth become map points. Until then:
//     kInitializing, identity pose.
//  3. Predict the pose with constant velocity (the last frame-to-frame
//     motion scaled by the time since the last frame, at most 4x).
//  4. Coarse: project the map points matched in the last frame, match in a
//     window of coarse_radius px (x level scale; retried with wide_radius),
//     keep the matches consistent in rotation, optimise the pose. If that
//     fails (or there is no motion model yet), match descriptors against the
//     reference keyframe and optimise from the prediction. If that fails
//     too, relocalise (step 7).
//  5. Fine: the local map (points of the local_keyframes keyframes that
//     share most points with the coarse matches, plus the recent_keyframes
//     newest ones) is projected with the coarse pose and matched in a window
//     of fine_radius px (x level scale); the final pose comes from all
//     matches. Fewer than min_inliers inliers with non-zero weight -> lost.
//  6. Keyframe when the frame tracks less than keyframe_tracked_ratio of the
//     reference keyframe's points seen by two keyframes, when few near points
//     are tracked while many are not (fewer than 100 tracked and more than
//     70 untracked, as ORB-SLAM), when tracked points cover less than
//     keyframe_min_coverage of the 8x6 image cells holding near features
//     with depth, or every keyframe_max_frames frames. A keyframe turns its
//     unmatched features with depth and a static weight >= min_point_weight
//     into map points (all nearer than close_depth, and the nearest others
//     up to min_new_points). Points found in fewer than cull_min_found_ratio
//     of the frames that should have seen them (after cull_min_visible such
//     frames) are culled.
//  7. Lost: the relocalisation_candidates keyframes with the best
//     bag-of-words score (tracker/backend/vocabulary.h, bow_database.h;
//     relocalisation_bow, once a vocabulary exists), as many whose
//     thumbnails (40x30, zero-mean, normalised) look most like the frame
//     (relocalisation_thumbnails), and the reference keyframe, are matched by
//     descriptor; PnP RANSAC (cv::solvePnPRansac, EPnP, 4 px) on their map
//     points, motion-only BA, then a search of the local map (twice the fine
//     window); success needs relocalisation_min_inliers inliers and returns
//     kRelocalized. While lost, every frame tries again; the pose reported
//     is the last one. With restart_after_lost = n > 0, after n frames lost
//     in a row the next frame that fails to relocalise starts a new map
//     (when it has min_init_features features with depth) at the pose the motion from
//     before the loss predicts over the gap (the last pose without one), so
//     that the trajectory goes on in the same world frame (TrackResult::
//     map_restarted; the old map is dropped). For a vehicle driving on,
//     where the keyframes behind cannot be recognised ahead.
//  8. Back end after a keyframe (local_ba.enabled): local BA of the new
//     keyframe, its local_ba.max_keyframes most covisible keyframes and the
//     points they see, the other keyframes seeing those points fixed
//     (tracker/backend/local_ba.h); BA outlier observations are erased;
//     then redundant local keyframes are culled
//     (tracker/backend/keyframe_culling.h). With local_ba.threaded the solve
//     runs on a back-end thread on a snapshot and is applied at the start of
//     a later Track call (results then depend on timing unless
//     local_ba.fixed_lag > 0); without it, on the tracking thread inside
//     Track (deterministic), applied at once, or with local_ba.fixed_lag > 0
//     at the frame a threaded run applies it (the same trajectory).
//  9. Loops after a keyframe (loops.enabled), before its local BA: the
//     bag-of-words candidates that are not covisible neighbours, consistent
//     over loops.min_consistent keyframes and verified by 3D-3D RANSAC
//     (tracker/backend/loop_detection.h); the best closes the loop: the
//     essential graph is optimised, keyframe poses and map points corrected,
//     the verified point pairs fused (tracker/backend/loop_correction.h),
//     then (loops.global_ba) a BA of all keyframes and points.
//     A local BA in flight is finished and applied first. Without
//     loops.threaded all of it runs on the tracking thread inside Track
//     (deterministic); the frame that closes a loop reports
//     TrackResult::loop_closed and its corrected pose. With loops.threaded
//     the tracking thread only copies the map and the BoW database for the
//     loop worker (tracker/backend/loop_worker.h), which detects and closes
//     the loop on that copy; the outcome is applied to the live map at the
//     start of a later Track call (loops.fixed_lag frames after the keyframe,
//     or when ready), whose result reports loop_closed: keyframes and points
//     made since the copy move as the closing keyframe moved. Without
//     loops.threaded but with loops.fixed_lag > 0 the same copy is processed
//     on the tracking thread and applied as late (the threaded trajectory).
//
// Rolling shutter (rolling_shutter_readout > 0): image rows are read one
// after the other, so under fast rotation a frame is not one pose. With the
// frame's motion from the constant-velocity model (twist xi per second) the
// camera that read row v is Exp(xi * tau) * cam_from_world, tau =
// readout * (v / (H - 1) - 0.5), i.e. the estimated pose is the middle
// row's. The optimiser, the projection search and the creation of map
// points all use it. A keyframe made without a motion model (the first one)
// has its points placed again once the next frame gives the motion. On TUM
// fr1/rpy (Kinect v1, 25 ms) this takes the ATE from about 4 cm to about
// 1.3 cm.
//
// Not thread-safe: one tracker per stream.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/camera.h"
#include "tracker/backend/keyframe_culling.h"
#include "tracker/backend/local_ba.h"
#include "tracker/backend/loop_detection.h"
#include "tracker/backend/vocabulary.h"
#include "tracker/orb_extractor.h"
#include "tracker/pose_optimizer.h"
#include "tracker/stereo/stereo_features.h"
#include "tracker/tracker.h"

namespace dypho {

struct OrbTrackerOptions {
  OrbExtractorOptions extractor;    // feature extraction
  // Stereo without a depth image: the frame's right image gives its
  // features' depth by sparse matching (tracker/stereo/stereo_features.h)
  // when stereo.baseline > 0.
  StereoFeatureOptions stereo;
  PoseOptimizerOptions optimizer;   // motion-only bundle adjustment (virtual_baseline for depth)
  double min_depth = 0.1;           // [m] nearer depth readings are ignored, > 0
  double max_depth = 8.0;           // [m] farther depth readings are ignored, > min_depth
  double max_depth_spread = 0.05;   // a reading whose 3x3 neighbourhood spans more than this fraction of it is an edge and ignored, > 0
  double close_depth = 3.2;         // [m] keyframes create points for all unmatched features nearer than this (ORB-SLAM: 40 baselines), > 0
  int min_new_points = 100;         // keyframes create at least this many points (nearest first) when depth allows, >= 0
  double min_point_weight = 0.5;    // features with a smaller static weight never become map points, [0, 1]
  int min_init_features = 100;      // features with depth needed to start the map, >= 10
  int restart_after_lost = 0;       // after this many frames lost in a row a new map is started (step 7), >= 0 (0 = never)
  int local_keyframes = 10;         // covisible keyframes whose points form the local map, >= 1
  int recent_keyframes = 2;         // newest keyframes always in the local map, >= 0
  double coarse_radius = 15.0;      // [px] window (x level scale) for the last frame's points at the predicted pose, > 0
  double wide_radius = 40.0;        // [px] retry window when the coarse search finds too few, >= coarse_radius
  double fine_radius = 4.0;         // [px] window (x level scale) for the local map at the coarse pose, > 0
  int max_projection_distance = 50; // Hamming threshold of matches by projection [bits], 1..256
  int max_keyframe_distance = 50;   // Hamming threshold of descriptor matching to keyframes [bits], 1..256
  double match_ratio = 0.9;         // best / second-best distance limit (projection search), (0, 1]
  double keyframe_match_ratio = 0.8;// best / second-best distance limit (keyframe matching), (0, 1]
  int min_coarse_inliers = 20;      // coarse stage succeeds with this many inliers, >= 6
  // The coarse stage also matches up to this many temporary points made
  // from the last frame's features with depth that matched no map point,
  // nearest first (ORB-SLAM2's "visual odometry" points, Mur-Artal and
  // Tardos 2017); they never enter the map. 0 = none, >= 0.
  int last_frame_points = 0;
  int min_inliers = 30;             // the frame is tracked with this many inliers, >= 6
  int relocalisation_min_inliers = 50;  // relocalisation succeeds with this many inliers, >= 6
  int relocalisation_candidates = 5;    // keyframes tried per relocalisation attempt and per cue, >= 1
  bool relocalisation_bow = true;       // candidates by bag-of-words score (tracker/backend/vocabulary.h)
  bool relocalisation_thumbnails = true;  // candidates by thumbnail correlation
  // Bag of words: a vocabulary file (`dypho vocab train`), or empty: the
  // vocabulary is trained at start-up from the descriptors of the first
  // vocabulary_train_keyframes keyframes (with `vocabulary` options); until
  // then relocalisation has the thumbnail cue only.
  std::string vocabulary_path;
  int vocabulary_train_keyframes = 5;   // >= 1
  VocabularyOptions vocabulary{10, 3, 10, 1};  // start-up training: branching 10, 3 levels (<= 1000 words)
  // A keyframe at least every so many tracked frames, >= 1. 5: frequent
  // keyframes, redundant ones culled after the local BA, as ORB-SLAM does
  // (tum_fr1_rpy_head250 ATE 1.13 -> 0.95 cm against 30, walkers 1.2-1.9 ->
  // 1.0-1.2 cm; BENCHMARKS.md "The tracker's keyframe period").
  int keyframe_max_frames = 5;
  double keyframe_tracked_ratio = 0.75; // keyframe when tracking fewer than this fraction of the reference keyframe's points, [0, 1]
  double keyframe_min_coverage = 0.5;   // keyframe when inliers cover less than this fraction of the 8x6 cells with depth features, [0, 1]
  double rolling_shutter_readout = 0.0;  // [s] time to read the image from the first to the last row; 0 = global shutter, >= 0
  double cull_min_found_ratio = 0.25;   // a point found in fewer than this fraction of its predicted sightings is culled, [0, 1]
  int cull_min_visible = 5;             // ... once it was predicted visible at least this often, >= 1
  LocalBaOptions local_ba;              // back end: local bundle adjustment (step 8)
  KeyframeCullingOptions keyframe_culling;  // back end: redundant keyframes (when local_ba.cull_keyframes)
  LoopClosingOptions loops;             // back end: loop detection and closure (step 9)

  bool IsValid(std::string* error) const;
};

// A loop the back end closed.
struct LoopRecord {
  double timestamp = 0.0;      // [s] the frame that closed it (the new keyframe)
  int keyframe = -1;           // the new keyframe
  int matched = -1;            // the old keyframe at the same place
  double score = 0.0;          // BoW score of the pair
  int inliers = 0;             // 3D-3D inliers of the verification
  int fused = 0;               // map points fused
  double translation = 0.0;    // [m] how far the correction moved the new keyframe
  double rotation_deg = 0.0;   // [deg] how far it turned it
  double pose_graph_ms = 0.0;  // [ms] essential-graph optimisation
  double global_ba_ms = 0.0;   // [ms] the global BA after it (loops.global_ba)
  long applied_frames_later = 0;  // frames between the keyframe and the closure's application (threaded)
};

// What the back end did so far (diagnostics and benchmarks).
struct OrbBackendStats {
  int local_ba_runs = 0;          // local BAs solved and applied
  int local_ba_skipped = 0;       // keyframes without a BA of their own (threaded: the worker was busy)
  double local_ba_ms = 0.0;       // [ms] total solve time (the worker's time when threaded)
  double local_ba_max_ms = 0.0;   // [ms] longest solve
  long erased_observations = 0;   // BA outlier observations removed
  int culled_keyframes = 0;       // redundant keyframes culled
  long released_points = 0;       // bad map points whose slots were released for new points
  int loop_queries = 0;           // loop detections run (one per keyframe once the map is large enough)
  double loop_query_ms = 0.0;     // [ms] total detection time (BoW query, consistency, verification)
  double loop_query_max_ms = 0.0; // [ms] longest detection
  int loop_candidates = 0;        // BoW candidates above the score, over all queries
  int loop_rejected = 0;          // consistent candidates that failed geometric verification
  double pose_graph_ms = 0.0;     // [ms] total essential-graph optimisation time
  double global_ba_ms = 0.0;      // [ms] total global-BA time after loop closures
  double loop_snapshot_ms = 0.0;  // [ms] threaded loops: total time copying the map for the worker (tracking thread)
  double loop_snapshot_max_ms = 0.0;  // [ms] longest copy
  std::vector<LoopRecord> loops;  // loops closed, in order
};

class OrbTracker : public Tracker {
 public:
  // Throws InvalidInput naming the field for invalid options or camera.
  OrbTracker(const Camera& camera, const OrbTrackerOptions& options = OrbTrackerOptions());
  ~OrbTracker() override;
  OrbTracker(const OrbTracker&) = delete;
  OrbTracker& operator=(const OrbTracker&) = delete;

  TrackResult Track(const TrackerFrame& frame) override;
  // The grey image and OrbExtractor::Prepare (pyramid, blur, main FAST pass
  // at the last frame's thresholds less a margin) of the left image.
  TrackerPrepareJob PrepareJob(const cv::Mat& image) const override;
  void Reset() override;
  std::string Name() const override { return "orb"; }

  const OrbTrackerOptions& options() const;
  const Camera& camera() const;
  // Keyframes made so far (culled ones included).
  int num_keyframes() const;
  // Keyframes not culled.
  int num_live_keyframes() const;
  // Map points not culled.
  int num_map_points() const;
  // Map point slots: live, culled and released ones (a released slot is
  // reused by a new point); what the point storage grows with.
  long num_map_point_slots() const;
  // Keyframes in the bag-of-words database (0 until a vocabulary exists).
  int num_bow_entries() const;
  // Whether a vocabulary is loaded or trained.
  bool has_vocabulary() const;
  const OrbBackendStats& backend_stats() const;
  // The ORB extraction of the last Track call (counts, stage times).
  const OrbExtractionStats& last_extraction_stats() const;
  // Threaded back end: waits for the BA in flight and the loop queries in
  // flight and applies them (no-op otherwise). Call before reading keyframe
  // poses at the end of a run.
  void FlushBackend();
  // The current pose of keyframe `id` (refined by the back end; a culled
  // keyframe keeps its last one). Throws InvalidInput for an unknown id.
  Rigid3d KeyframePose(int id) const;
  // Geometric verification (step 9) of keyframe `candidate` as a loop for
  // keyframe `kf` (diagnostics and tests: an injected candidate). Throws
  // InvalidInput for unknown or culled keyframes.
  LoopCandidateMatch VerifyLoopCandidate(int kf, int candidate) const;
  // The local BA window of keyframe `kf` as the back end would build it now
  // (diagnostics and tests: the BA solvers compared on a real window).
  // Throws InvalidInput for an unknown or culled keyframe.
  LocalBaProblem LocalBaWindow(int kf) const;
  // The timestamp of keyframe `id` (culled ones too). Throws InvalidInput
  // for an unknown id.
  double KeyframeTimestamp(int id) const;
  // The poses of the keyframes not culled, as (timestamp, cam_from_world).
  std::vector<std::pair<double, Rigid3d>> KeyframePoses() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho
