// The dense-mapping thread: the static dense point-cloud map of the nearshore
// USV SLAM of Zhang et al. (J. Mar. Sci. Eng. 2025), beside the Gaussian
// mapper. Each keyframe (its depth with dynamic, water and sky pixels
// removed: engine/dense/keyframe_points.h) is merged into a world voxel map
// (engine/dense/voxel_map.h); pose changes move the keyframe's points; the
// export removes statistical outliers and adds normals
// (engine/dense/dense_cloud.h).
//
// Threads: Add and SetPose check their input on the caller's thread and
// queue the work for the dense thread, which never blocks the caller for
// longer than the copy into the queue (the queue holds at most
// queue_capacity keyframes; Add waits for room beyond that: no keyframe is
// dropped). Work is applied in the order it was queued. Cloud(), Save() and
// stats() first wait for the queue. With `synchronous` there is no thread:
// Add and SetPose do the work before they return (deterministic; the map
// does not depend on timing either way, only on the keyframes and poses).
// All methods are thread-safe.
#pragma once

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <variant>

#include "common/camera.h"
#include "engine/dense/dense_cloud.h"
#include "engine/dense/keyframe_points.h"
#include "engine/dense/voxel_map.h"

namespace dypho {

struct DenseMapOptions {
  bool enabled = true;         // build the dense map (dense.ply) at all
  DensePointOptions points;    // which pixels of a keyframe are used
  VoxelMapOptions map;         // voxel size and memory bound
  DenseCloudOptions cloud;     // outlier removal and normals at export
  int queue_capacity = 8;      // keyframes waiting for the dense thread before Add waits
  void Validate() const;       // throws InvalidInput naming the field
};

struct DenseMapStats {
  VoxelMapStats map;
  int keyframes_added = 0;       // keyframes integrated (with or without points)
  int empty_keyframes = 0;       // of them with no usable pixel (all masked, no depth)
  int pose_updates = 0;          // contributions moved to a new pose
  double total_ms = 0;           // [ms] dense-thread time on keyframes (extraction + integration)
  double max_ms = 0;             // [ms] the slowest keyframe
  double mean_ms() const { return keyframes_added ? total_ms / keyframes_added : 0.0; }
};

class DenseMapper {
 public:
  // `camera`: the ideal pinhole camera of the (undistorted) keyframes.
  DenseMapper(const Camera& camera, const DenseMapOptions& options, bool synchronous);
  ~DenseMapper();  // finishes the queued work
  DenseMapper(const DenseMapper&) = delete;
  DenseMapper& operator=(const DenseMapper&) = delete;

  // Queues keyframe `id` (its pose is keyframe.cam_from_world). Throws
  // InvalidInput for an id already added, a non-finite pose or images of the
  // wrong size (naming the field). An all-masked keyframe or one without
  // depth is added with no points (counted in stats().empty_keyframes).
  void Add(int id, KeyframeInput keyframe);
  // Moves keyframe `id`'s points to a new pose. Throws InvalidInput for an
  // id never added or a non-finite pose.
  void SetPose(int id, const Rigid3d& cam_from_world);
  bool Has(int id) const;
  void Wait() const;  // until the queue is empty
  ColoredPoints Cloud() const;                 // Wait, then the cleaned cloud
  void Save(const std::string& path) const;    // Cloud() as a PLY, written atomically
  DenseMapStats stats() const;                 // Wait, then the counters

 private:
  struct AddJob {
    int id;
    KeyframeInput keyframe;
  };
  struct PoseJob {
    int id;
    Rigid3d cam_from_world;
  };
  using Job = std::variant<AddJob, PoseJob>;
  void Apply(Job job);  // caller holds map_mutex_
  void Loop();

  const Camera camera_;
  const DenseMapOptions options_;
  const bool synchronous_;
  mutable std::mutex queue_mutex_;
  mutable std::condition_variable queue_cv_, idle_cv_, space_cv_;
  std::deque<Job> queue_;     // queue_mutex_
  std::set<int> ids_;         // every id added (queue_mutex_)
  int queued_keyframes_ = 0;  // AddJobs in queue_ (queue_mutex_)
  bool busy_ = false;         // the thread is applying a job (queue_mutex_)
  bool stop_ = false;
  mutable std::mutex map_mutex_;
  VoxelMap map_;              // map_mutex_
  DenseMapStats stats_;       // map_mutex_
  std::thread thread_;
};

}  // namespace dypho
