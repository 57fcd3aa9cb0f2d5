// Keyframe pixels that later (and earlier) frames see through: a free-space
// test against the depth of the frames around a keyframe. A pixel of the
// keyframe at depth z is a point X in the world; a frame j whose depth at X's
// projection is clearly farther than X's depth in j looked through the place
// where X was, so X was not there at j's time: X belonged to something that
// moved (a person the detector missed, a person hidden behind another in one
// box, a person cut by the image border). Enough such frames make the pixel
// dynamic for the map. It needs frames after the keyframe, so the engine
// holds each keyframe back for `window` frames (SeenThroughQueue).
//
// The test is the free-space carving of volumetric fusion (Curless & Levoy
// 1996) applied per pixel of one frame, as dynamic RGB-D SLAM systems use it
// to find moving points (e.g. ReFusion, Palazzolo et al. 2019).
#pragma once

#include <deque>
#include <utility>
#include <vector>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/map/mapper.h"

namespace dypho {

struct SeenThroughOptions {
  bool enabled = false;
  int window = 30;           // [frames] before and after a keyframe (the engine holds keyframes this long)
  int neighbours = 10;       // frames of the window tested, evenly spread over it
  int votes = 3;             // frames that must see through a pixel for it to be dynamic
  int downscale = 4;         // the test runs on blocks of this many pixels squared
  float margin_m = 0.10f;    // [m] how much farther a frame must see, at least ...
  float margin_rel = 0.05f;  // ... or this fraction of the depth, the larger
  int dilate = 1;            // [blocks] the mask grows by this much
  // [blocks] a neighbour's depth is the nearest within this many blocks, so
  // that a pose or rolling-shutter error of up to edge_blocks * downscale
  // pixels does not see past a depth edge
  int edge_blocks = 1;
  // [s] rolling shutter, first row to last (the convention of
  // engine/map/sensor_model.h: row v sees Exp(omega tau) cam, tau =
  // readout (v / (H - 1) - 0.5), cam the frame's pose); 0 = global shutter.
  // Not an option of the run: dypho run sets the camera's readout.
  double readout = 0.0;
  void Validate() const;     // throws InvalidInput naming the field
};

// A frame's depth at 1/downscale resolution: each block's nearest valid
// depth (0 where the block has none), so that a test against it is
// conservative at depth edges. `depth`: pinhole (undistorted), [m].
ImageF MinPoolDepth(const ImageF& depth, int downscale);

struct DepthAtPose {
  ImageF depth;            // MinPoolDepth of the frame
  Rigid3d cam_from_world;
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();  // [rad/s] rotation rate, for options.readout
};

// 255 where at least options.votes of `others` see through the keyframe's
// pixel (camera size, like `depth`), 0 elsewhere. `camera`: the pinhole
// camera of `depth` (full size); `others` hold MinPoolDepth images with the
// same options.downscale.
// `omega`: the keyframe's rotation rate (with options.readout).
ImageU8 SeenThroughMask(const Camera& camera, const ImageF& depth, const Rigid3d& cam_from_world,
                        const std::vector<const DepthAtPose*>& others, const SeenThroughOptions& options,
                        const Eigen::Vector3d& omega = Eigen::Vector3d::Zero());

// Holds keyframes until the frames after them have come (options.window), then
// adds their seen-through pixels to their dynamic masks. One thread at a time.
class SeenThroughQueue {
 public:
  SeenThroughQueue(const Camera& pinhole, const SeenThroughOptions& options);
  // Every frame with depth (pinhole, [m]), in order; returns its index (0,
  // 1, ...). A keyframe is a frame too: Add it, then Hold it.
  long long Add(const ImageF& depth, const Rigid3d& cam_from_world,
                const Eigen::Vector3d& omega = Eigen::Vector3d::Zero());
  // The keyframe `id`, the frame Added as `frame`, waits for the frames after
  // it. The test uses the pose it has now (the frames' poses are as Added);
  // a later SetPose changes only the pose it is mapped with.
  void Hold(int id, KeyframeInput input, long long frame);
  // The keyframes whose window has passed (all of them with `all`, at the
  // end of the stream), in the order they were held, masks extended.
  std::vector<std::pair<int, KeyframeInput>> Release(bool all);
  // A held keyframe's pose: set (a correction) or read; false when `id` is
  // not held.
  bool SetPose(int id, const Rigid3d& cam_from_world);
  bool GetPose(int id, Rigid3d* cam_from_world) const;
  int held() const { return static_cast<int>(held_.size()); }
  long long masked_pixels() const { return masked_pixels_; }  // pixels made dynamic so far

 private:
  struct Held {
    int id;
    long long frame;  // index of its frame
    KeyframeInput input;
    Rigid3d test_pose;  // its pose when held, in the frames' terms
    Eigen::Vector3d omega;
  };
  Camera camera_;
  SeenThroughOptions options_;
  std::deque<DepthAtPose> frames_;  // the last 2 * window + 1 frames
  long long next_frame_ = 0;        // index of the next frame Added
  std::deque<Held> held_;
  long long masked_pixels_ = 0;
};

}  // namespace dypho
