// Options of the synthetic nearshore (harbour) sequence generator
// (`dypho synth --scene shore`, engine/synth/shore/shore_scene.h).
#pragma once

#include <cstdint>
#include <string>

#include "common/camera.h"

namespace dypho {

struct ShoreSynthOptions {
  int width = 320;               // image width [px], >= 16
  int height = 240;              // image height [px], >= 16
  int frames = 100;              // number of frames, >= 1
  double fps = 15.0;             // frame rate [Hz], (0, 1000]
  double start_time = 1.0e6;     // timestamp of frame 0 [s], >= 0 (rounded to 1 us)
  uint64_t seed = 1;             // textures, pedestrians' paths, ripples' phases, clouds
  int num_pedestrians = 3;       // people walking along the shore, 0..6
  bool boat = true;              // a boat passing between the camera and the shore
  double boat_speed = 2.0;       // the passing boat's speed [m/s], [0.2, 10]
  double boat_speed_own = 0.45;  // the camera boat's forward speed along the shore [m/s], [0, 5]
  double roll_deg = 3.0;         // the camera boat's roll amplitude [deg], [0, 20]
  double depth_max = 40.0;       // depth beyond this reads 0 [m], > 0
  double depth_factor = 1000.0;  // depth PNG units per metre, > 0 (1000: up to 65 m)
  bool stereo = false;           // also write stereo/ (left/, right/, stereo.yaml; generic stereo layout)
  double baseline = 0.12;        // stereo baseline [m] (ZED-like), (0, 2]
  // Focal length [px]; 0 = 262.5 * width / 320 (62 deg horizontal field of view).
  double focal = 0.0;

  // True when every field is in range; otherwise `error` names the field and
  // the violated constraint.
  bool IsValid(std::string* error) const;
  // Throws InvalidInput with IsValid's message.
  void Validate() const;
  // The pinhole camera (no distortion; square pixels; principal point at the image centre).
  Camera MakeCamera() const;
  // Timestamp of frame `index` [s], rounded to microseconds.
  double Timestamp(int index) const;
};

}  // namespace dypho
