// The tracker interface: something that gives every RGB-D frame a camera
// pose. The built-in implementation is the ORB tracker (tracker/orb_tracker.h);
// a pose file or a host SLAM system can stand in for it behind the same
// interface.
//
// Frames are cv::Mat views (wrap common Image types with tracker/cv_view.h).
// Bad input (an empty image, sizes that disagree with the camera, wrong
// pixel types) throws InvalidInput naming the field; a frame the tracker
// cannot use (black, blurred, no depth before the map exists, a view it has
// never seen) is a status, never an exception.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/rigid3.h"

namespace dypho {

enum class TrackStatus {
  kInitializing,  // no map yet (e.g. no valid depth so far); the pose is the identity
  kOk,            // tracked
  kRelocalized,   // tracking was lost and the pose was found again against the map
  kLost,          // no pose for this frame; cam_from_world repeats the last known pose
};

// "initializing", "ok", "relocalized", "lost".
const char* TrackStatusName(TrackStatus status);

// Where a tracked frame's first pose estimate came from (diagnostics: a
// healthy tracker on a smooth path takes almost every frame from the last
// frame; many keyframe fallbacks mean the motion prediction or the last
// frame's matches are failing).
enum class CoarseSource {
  kNone,               // not tracked, or a tracker that does not say
  kStart,              // the frame that started the map
  kLastFrame,          // the last frame's points at the predicted pose
  kReferenceKeyframe,  // descriptor matching against the reference keyframe
  kRelocalisation,     // a place-recognition candidate keyframe
};
// "none", "start", "last frame", "reference keyframe", "relocalisation".
const char* CoarseSourceName(CoarseSource source);
// True for kOk and kRelocalized (the pose was estimated for this frame).
inline bool IsTracked(TrackStatus status) {
  return status == TrackStatus::kOk || status == TrackStatus::kRelocalized;
}

// What a tracker computes from a frame's image alone, before the frame's
// masks exist (OrbTracker: the ORB pyramid, blur and main FAST pass), so that
// it can run on another thread while the masks are made. Each tracker has
// its own derived type.
struct TrackerPrepared {
  virtual ~TrackerPrepared() = default;
};
// Makes a TrackerPrepared (or null where there is nothing to prepare).
using TrackerPrepareJob = std::function<std::shared_ptr<const TrackerPrepared>()>;

struct TrackerFrame {
  double timestamp = 0.0;  // [s]
  cv::Mat image;           // CV_8UC3 (RGB order) or CV_8UC1 grey, camera size; required
  cv::Mat depth;           // CV_32FC1 camera z [m], camera size; 0, negative or non-finite = no reading; may be empty
  cv::Mat dynamic_mask;    // optional CV_8UC1, camera size; non-zero = dynamic (no features there)
  cv::Mat static_weight;   // optional CV_32FC1, camera size; 1 = surely static .. 0 = surely dynamic
  // Optional: the rectified right image of a stereo pair (CV_8UC3 RGB or
  // CV_8UC1, camera size). A tracker that can (OrbTracker with
  // stereo.baseline > 0) takes the features' depth from it when `depth` is empty.
  cv::Mat right_image;
  // Optional, with right_image: a coarse depth of the pair (CV_32FC1 [m], the
  // camera size divided by an integer, e.g. a half-resolution dense
  // disparity's depth). OrbTracker then searches each feature's match along
  // the row around the prior instead of extracting right-image features
  // (StereoFeatureDepthsFromPrior).
  cv::Mat stereo_prior_depth;
  // Optional: the result of this tracker's PrepareJob(image) for this very
  // image. The pose is the same with or without it; without, Track does the
  // work itself.
  std::shared_ptr<const TrackerPrepared> prepared;
};

// A feature of the frame, for the mapper (densification around features)
// and for diagnostics.
struct TrackedFeature {
  Eigen::Vector2f pixel = Eigen::Vector2f::Zero();        // undistorted position [px]
  Eigen::Vector2f image_pixel = Eigen::Vector2f::Zero();  // position in the input (distorted) image [px]
  float weight = 1.0f;    // static weight in [0, 1]
  float depth = 0.0f;     // depth reading used [m]; 0 = none
  int level = 0;          // pyramid level
  long map_point = -1;    // id of the matched map point when it is an inlier, else -1 (a culled point's id may later name a new one)
};

struct TrackTiming {
  double extract_ms = 0.0;   // grey conversion and ORB extraction
  double track_ms = 0.0;     // matching and pose optimisation (and relocalisation)
  double map_ms = 0.0;       // keyframe insertion and culling
  double total_ms = 0.0;     // the whole Track call
};

struct TrackResult {
  TrackStatus status = TrackStatus::kLost;
  double timestamp = 0.0;                // [s] the frame's timestamp
  Rigid3d cam_from_world;                // the estimate (see TrackStatus for the other cases)
  std::vector<TrackedFeature> features;  // every extracted feature
  int num_matches = 0;                   // map-point matches fed to the final optimisation
  int num_inliers = 0;                   // matches kept by it
  bool is_keyframe = false;              // the frame became a keyframe
  bool loop_closed = false;              // the back end closed a loop in this call: keyframe poses moved
  int reference_keyframe = -1;           // the tracker's keyframe nearest in content (the new one for a keyframe); -1 = none
  CoarseSource coarse_source = CoarseSource::kNone;  // where the first pose estimate came from
  int coarse_matches = 0;                // matches of that first stage
  std::string message;                   // why the frame is lost or not initialised; empty when tracked
  TrackTiming timing;
  bool map_restarted = false;            // lost for too long: this frame started a new map (OrbTrackerOptions::restart_after_lost)
};

class Tracker {
 public:
  virtual ~Tracker() = default;
  // Estimates the pose of the next frame of the stream.
  virtual TrackResult Track(const TrackerFrame& frame) = 0;
  // The image-only part of Track for the next frame's `image`, as a job that
  // may run on any thread; pass its result in TrackerFrame::prepared. Call
  // it between Track calls; the job must finish before the Track call it
  // serves, and the tracker must outlive it. An empty job: nothing to
  // prepare (the default).
  virtual TrackerPrepareJob PrepareJob(const cv::Mat& image) const {
    (void)image;
    return {};
  }
  // Forgets the map and the motion; the next frame starts a new map.
  virtual void Reset() = 0;
  // A short name for logs ("orb").
  virtual std::string Name() const = 0;
};

// Throws InvalidInput naming the field when `frame` does not fit `camera`
// (empty image, wrong sizes or pixel types).
void CheckTrackerFrame(const TrackerFrame& frame, const Camera& camera);

}  // namespace dypho
