// The engine's response to a loop closure in the ORB tracker (issue 17).
//
// Every tracked frame is remembered relative to the tracker keyframe it
// was tracked against (cam_from_keyframe), as ORB-SLAM writes its
// trajectories. When the tracker closes a loop and moves its keyframes,
// each frame's corrected pose is cam_from_keyframe * keyframe_from_world
// at the keyframe's new pose. The engine keyframes (made by the engine's
// own keyframe policy, matched by frame index) get these corrected poses
// through Engine::UpdateKeyframePose (their anchored Gaussians and dense
// points move), the run's trajectory is rewritten with them, and a short
// refinement (PipelineOptions::loop_refine_iterations steps) follows.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "common/rigid3.h"
#include "engine/eval/trajectory.h"

namespace dypho {

class Engine;
class OrbTracker;
struct TrackResult;

// A corrected pose for the frame with dataset index `frame`.
struct PoseCorrection {
  long frame = -1;
  Rigid3d cam_from_world;
};

// What was applied after one loop closure (report.md, metrics.json).
struct LoopResponseRecord {
  long frame = -1;             // dataset index of the frame that closed the loop
  long matched_frame = -1;     // dataset index of the matched (old) keyframe's frame; -1 = unknown
  int inliers = 0;             // 3D-3D inliers of the verification
  double correction_cm = 0.0;  // the closing keyframe's correction [cm]
  double correction_deg = 0.0; // ... [deg]
  int frames_corrected = 0;    // trajectory poses moved
  int keyframes_moved = 0;     // engine keyframes given a corrected pose
  int keyframes_skipped = 0;   // corrections without an engine keyframe
  int candidates_moved = 0;    // the engine's keyframe candidate (not emitted yet) given its corrected pose
  int refine_steps = 0;        // optimisation steps asked of the mapping thread after it
};

// Applies `corrections` to engine keyframes: `engine_keyframe_of_frame`
// maps a dataset frame index to the engine keyframe made from it; a
// correction for a frame the engine never took as a keyframe is skipped
// (counted in *skipped when given). Returns the keyframes updated.
int ApplyKeyframeCorrections(const std::vector<PoseCorrection>& corrections,
                             const std::map<long, int>& engine_keyframe_of_frame,
                             const std::function<void(int id, const Rigid3d& cam_from_world)>& update,
                             int* skipped = nullptr);

class LoopResponse {
 public:
  // After tracker.Track(...) returned `result` for dataset frame `frame`
  // (the trajectory got the frame's line just before).
  void NoteFrame(long frame, double timestamp, const TrackResult& result, const OrbTracker& tracker);
  // The engine made keyframe `id` from the frame with `timestamp`.
  void NoteEngineKeyframe(int id, double timestamp);
  // The poses of every anchored frame at the tracker's current keyframe
  // poses.
  std::vector<PoseCorrection> Corrections(const OrbTracker& tracker) const;
  // The tracker closed a loop in the last Track call: moves the engine's
  // keyframes and the trajectory's poses (world_from_cam per noted frame,
  // in order) and asks the engine for `refine_steps` steps (RequestRefine:
  // on the mapping thread, the caller goes on). Returns what it did.
  LoopResponseRecord Respond(const OrbTracker& tracker, Engine* engine, Trajectory* trajectory, int refine_steps);

 private:
  struct Frame {
    long frame = -1;
    double timestamp = 0.0;
    int keyframe = -1;           // tracker keyframe; -1 = keeps its pose
    Rigid3d cam_from_reference;  // cam_from_keyframe, or cam_from_world without a keyframe
    bool tracked = false;        // had a pose (lost frames repeat the last pose in the trajectory)
  };
  std::vector<Frame> frames_;                 // in order, one per trajectory line
  std::map<double, long> frame_of_timestamp_;
  std::map<long, int> engine_keyframe_of_frame_;
};

}  // namespace dypho
