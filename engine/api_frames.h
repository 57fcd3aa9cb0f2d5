// Frames as the embedding API receives them (engine/api.h): the pushed
// buffers copied and checked, the dense depth of a keyframe's stereo pair,
// the keyframe-mask hook's answer joined to a keyframe's mask, and the
// host's renders. Internal to the engine library.
#pragma once

#include <optional>
#include <vector>

#include "common/image.h"
#include "common/rigid3.h"
#include "engine/api.h"
#include "engine/map/keyframe_store.h"
#include "engine/map/mapper.h"
#include "engine/map/undistort.h"

namespace dypho {

inline bool FinitePose(const Rigid3d& p) { return p.translation.allFinite() && p.rotation.coeffs().allFinite(); }

// A frame as pushed: camera size, distorted; depth in metres (0 = none);
// rgb always, depth and mask empty when not given.
struct PushedFrame {
  double timestamp = 0.0;
  ImageU8 rgb;
  ImageF depth;
  ImageU8 mask;
  ImageU8 right;  // keyframe_depth_from_pair: the right image (depth is the preview)
};

// Copies `frame` (16-bit depth converted with options.depth_scale, invalid
// depths set to 0). Throws InvalidInput naming the field for a null rgb
// buffer, both depth buffers, a non-finite timestamp, pose or angular velocity.
PushedFrame CopyPushedFrame(const FrameBuffers& frame, const Rigid3d* cam_from_world, const EngineOptions& options);

// FrameBuffers::depth_timestamp: the undistorted depth `pinhole_depth` of
// `camera` (pinhole), captured `depth_dt` seconds after the colour image,
// moved to the colour image's pose `cam_from_world` (WarpDepth). The motion
// is the constant velocity between `previous` (the pose pushed at
// `previous_time`, when less than kMaxAngularVelocityGap older) and this pose;
// without it the rotation `omega` alone; without either, or |depth_dt| under
// 1 ms, the depth is returned unchanged.
ImageF DepthAtColourTime(ImageF pinhole_depth, const Camera& camera, double depth_dt,
                         const std::optional<Rigid3d>& previous, double previous_time, const Rigid3d& cam_from_world,
                         double time, const Eigen::Vector3d& omega);

// A pushed frame and the motion around it: what a keyframe input (or a
// held-back frame) is made from. A keyframe candidate keeps this and is
// made into a KeyframeInput only when the selector emits it.
struct KeyframeSource {
  PushedFrame pushed;
  double timestamp = 0.0;
  Rigid3d cam_from_world;
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();
  std::optional<Rigid3d> previous_pose;  // the pose pushed before, at previous_time
  double previous_time = 0.0;
  double depth_dt = 0.0;                 // depth capture time - colour time [s]
  std::vector<KeyframeFeature> features;
  std::optional<ImageF> pinhole_depth;   // KeyframeSourceDepth, when computed already
};

// `depth` (distorted, as pushed) undistorted and moved to the colour image's
// time (DepthAtColourTime with the source's motion).
ImageF KeyframeSourceDepth(const Undistorter& undistort, const ImageF& depth, const KeyframeSource& source);

// The keyframe input of `source`: undistorted colour, depth at the colour
// time, excluded pixels from the mask; with_right: the right image goes
// with it (a keyframe's dense depth from the pair).
KeyframeInput MakeKeyframeInput(const Undistorter& undistort, KeyframeSource source, bool with_right);

// The dense depth of a keyframe's pair (KeyframeInput::right_rgb, when
// set) in place of its preview depth; right_rgb is cleared. Returns the
// disparity's wall time [ms], 0 when there was no pair.
double ResolvePairDepth(KeyframeInput* input, const EngineOptions& options);

// The waiting keyframes' store as EngineOptions configure it.
KeyframeStoreOptions StoreOptionsFor(const EngineOptions& options);

// A view of `cloud` for Engine::Render (the mapper's SH degree, threads and
// background).
EngineRender RenderForHost(const GaussianCloud& cloud, const Camera& camera, const Rigid3d& cam_from_world,
                           kernels::CompositeMode mode, const EngineOptions& options);

// EngineOptions::keyframe_mask asked about `frame`: the frame's mask joined
// with the pixels it returns (255 = dynamic), or nullopt when it returns none
// (or there is no hook). Throws InvalidInput when the answer has the wrong size.
std::optional<ImageU8> AskKeyframeMask(const EngineOptions& options, PushedFrame frame);

}  // namespace dypho
