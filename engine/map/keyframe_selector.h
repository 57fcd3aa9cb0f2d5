// Choosing keyframes for the map: by new content and sharpness, not by a
// fixed motion step.
//
// A keyframe is due when the frame sees content that no keyframe so far
// sees (the fraction of its sampled static pixels that are unexplained is at
// least min_new_content), when the camera moved or turned more than
// max_translation / max_rotation_deg since the last keyframe, after
// max_frame_gap frames, and for the first frame. A point of the frame (its
// depth sampled on a grid of sample_step_px, dynamic pixels left out) is
// explained by a keyframe when it projects into that keyframe's image and
// agrees with the keyframe's own depth there (within
// visibility_tolerance x depth + 2 cm): the keyframe saw that surface. A
// point behind the keyframe's surface (occluded there), in front of it (free
// space there) or outside its view is not explained by it. This is the
// covisibility test of keyframe-based SLAM done on depth instead of map
// points. A sampled pixel without depth (out of the sensor's range, a dark
// or shiny surface) is explained when, put at the frame's median depth, it
// falls inside some keyframe's image: a frame turning to a far wall the
// sensor cannot measure still brings a keyframe.
//
// Sharpness: fast rotation blurs frames. When a keyframe is due, the next
// sharpness_window - 1 frames are candidates too and the sharpest of them
// becomes the keyframe, sharpness being the variance of the Laplacian of the
// grey image at half resolution over static pixels (Pech-Pacheco et al.,
// ICPR 2000). A frame much sharper than the keyframes that see its content
// is due too (sharper_ratio). The caller keeps the current best candidate's
// data (Offer says when to keep and when to emit).
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <vector>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/map/image_sharpness.h"  // ImageSharpness

namespace dypho {

// The largest KeyframePolicy::sharpness_window, and how many recent frames
// a caller remembers to find the frame a keyframe (or the candidate not
// emitted yet) was made from: more than any window.
constexpr int kMaxSharpnessWindow = 30;
constexpr size_t kKeyframeCandidateFrames = 64;
static_assert(kKeyframeCandidateFrames > static_cast<size_t>(kMaxSharpnessWindow));

struct KeyframePolicy {
  double max_translation = 0.10;      // [m] a keyframe is due after this camera motion since the last one
  double max_rotation_deg = 15.0;     // [deg] ... or this rotation
  int max_frame_gap = 30;             // [frames] ... or this many frames
  double min_new_content = 0.10;      // fraction of the frame's static pixels no keyframe explains (0 = pose rules only)
  int sample_step_px = 10;            // [px] depth sampling grid of the content test
  double visibility_tolerance = 0.05; // relative depth agreement of the content test (plus 2 cm)
  int sharpness_window = 8;           // [frames] a due keyframe is the sharpest of this many frames (1 = no wait), 1..kMaxSharpnessWindow
  // A keyframe is also due when the frame is this many times sharper than
  // the keyframes that see its content (median over its points of the
  // sharpest keyframe explaining each): fast rotation blurs most frames of
  // a sequence like TUM fr1/rpy, and the few sharp ones are the views the
  // map needs (0 = off).
  double sharper_ratio = 2.0;
  // The end of a sequence: the newest frame since the last keyframe that
  // sees at least this fraction of new content (the sharper of two within a
  // sharpness window) becomes a keyframe, as no later frame will bring it
  // (0 = off; needs the content test: min_new_content or sharper_ratio
  // > 0). Frames before the end need min_new_content.
  double tail_new_content = 0.02;
  void Validate() const;              // throws InvalidInput naming the field
};

// What the caller does with the frame it offered.
struct KeyframeDecision {
  bool keep = false;         // this frame is the best candidate so far: keep its data (replacing the kept one)
  bool emit = false;         // the kept candidate (after `keep`) becomes a keyframe now
  double new_content = 0.0;  // the frame's unexplained fraction (diagnostics)
  double sharpness = 0.0;    // its sharpness (diagnostics)
  double seen_sharpness = 0.0;  // median sharpness of the keyframes that see its points (diagnostics)
};

class KeyframeSelector {
 public:
  // `camera` is the camera of the offered images (distortion allowed).
  KeyframeSelector(const KeyframePolicy& policy, const Camera& camera);
  ~KeyframeSelector();
  KeyframeSelector(KeyframeSelector&&) noexcept;
  KeyframeSelector& operator=(KeyframeSelector&&) noexcept;

  // Offers the next frame: its pose, depth [m] (may be empty: such a frame
  // is never a keyframe), RGB (may be empty: sharpness 0) and dynamic mask
  // (may be empty).
  KeyframeDecision Offer(const Rigid3d& cam_from_world, const ImageF& depth, const ImageU8& rgb,
                         const ImageU8& dynamic_mask);
  // Whether a candidate is kept and not yet emitted (a sharpness window's,
  // or the tail candidate: see tail_new_content).
  bool pending() const;
  // Emits the kept candidate now (end of the sequence); false when none.
  bool Flush();
  // Keyframes emitted so far.
  int num_keyframes() const;
  // Forgets everything (e.g. after the tracker lost the camera).
  void Reset();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dypho
