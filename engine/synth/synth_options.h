// Options of the synthetic dynamic RGB-D sequence generator.
#pragma once

#include <cstdint>
#include <string>

#include "common/camera.h"

namespace dypho {

// Camera motion presets, shaped like the TUM RGB-D sequences of those names.
enum class SynthMotion {
  kXyz,         // translation along x, y, z (about +-0.25 m), small rotations
  kRpy,         // roll, pitch, yaw (about +-20 deg) about a fixed point, little translation
  kHalfsphere,  // camera on a half sphere (radius 1 m) looking at the room centre
  kStatic,      // fixed camera with a tiny jitter (a tripod on a soft floor)
  kLoop,        // laps of a circle (radius 0.5 m, 12 s a lap) looking outwards: revisits its start
};

// "xyz", "rpy", "halfsphere", "static", "loop".
std::string SynthMotionName(SynthMotion motion);
// Parses a name as printed by SynthMotionName; false when unknown.
bool ParseSynthMotion(const std::string& name, SynthMotion* motion);

struct SynthOptions {
  int width = 640;                         // image width [px], >= 16
  int height = 480;                        // image height [px], >= 16
  int frames = 120;                        // number of frames, >= 1
  double fps = 30.0;                       // frame rate [Hz], (0, 1000]
  double start_time = 1.0e6;               // timestamp of frame 0 [s], >= 0 (rounded to 1 us)
  uint64_t seed = 1;                       // seed for textures, walkers and depth noise
  SynthMotion motion = SynthMotion::kXyz;  // camera motion preset
  int num_walkers = 2;                     // moving occluders, 0..4 (0 = static scene)
  double walker_speed = 1.0;               // walkers' cruising speed [m/s], [0.2, 3]
  double max_coverage = 0.4;               // max fraction of the image walkers cover in any frame, (0, 1]
  bool depth_noise = true;                 // Kinect-like noise, holes and range limits on the sensor depth
  double depth_min = 0.3;                  // sensor range: nearer depth reads 0 [m], >= 0
  double depth_max = 8.0;                  // sensor range: farther depth reads 0 [m], > depth_min
  double depth_dropout = 0.005;            // probability of a random hole per pixel, [0, 1)
  double depth_factor = 5000.0;            // depth PNG units per metre (TUM: 5000), > 0
  // Intrinsics [px]; 0 = the Kinect default (fx = fy = 525, cx = 319.5,
  // cy = 239.5 at 640x480): fx = fy = 525 * width / 640 (square pixels), the
  // principal point at the image centre.
  double fx = 0.0;  // focal length x [px], 0 = default, else > 0
  double fy = 0.0;  // focal length y [px], 0 = default, else > 0
  double cx = 0.0;  // principal point x [px], 0 = default
  double cy = 0.0;  // principal point y [px], 0 = default

  // True when every field is in range; otherwise `error` names the field and
  // the violated constraint.
  bool IsValid(std::string* error) const;
  // Throws InvalidInput with IsValid's message.
  void Validate() const;
  // The pinhole camera these options describe (no distortion).
  Camera MakeCamera() const;
  // Timestamp of frame `index` [s], rounded to microseconds.
  double Timestamp(int index) const;
};

}  // namespace dypho
