#include "engine/synth/synth_options.h"

#include <cmath>
#include <sstream>

#include "common/check.h"

namespace dypho {

std::string SynthMotionName(SynthMotion motion) {
  switch (motion) {
    case SynthMotion::kXyz:
      return "xyz";
    case SynthMotion::kRpy:
      return "rpy";
    case SynthMotion::kHalfsphere:
      return "halfsphere";
    case SynthMotion::kStatic:
      return "static";
    case SynthMotion::kLoop:
      return "loop";
  }
  return "unknown";
}

bool ParseSynthMotion(const std::string& name, SynthMotion* motion) {
  for (SynthMotion m :
       {SynthMotion::kXyz, SynthMotion::kRpy, SynthMotion::kHalfsphere, SynthMotion::kStatic, SynthMotion::kLoop}) {
    if (name == SynthMotionName(m)) {
      *motion = m;
      return true;
    }
  }
  return false;
}

bool SynthOptions::IsValid(std::string* error) const {
  std::ostringstream msg;
  auto finite = [](double v) { return std::isfinite(v); };
  if (width < 16 || width > 8192) {
    msg << "width must be in [16, 8192] (got " << width << ")";
  } else if (height < 16 || height > 8192) {
    msg << "height must be in [16, 8192] (got " << height << ")";
  } else if (frames < 1 || frames > 1000000) {
    msg << "frames must be in [1, 1000000] (got " << frames << ")";
  } else if (!(finite(fps) && fps > 0.0 && fps <= 1000.0)) {
    msg << "fps must be in (0, 1000] (got " << fps << ")";
  } else if (!(finite(start_time) && start_time >= 0.0 && start_time < 1e10)) {
    msg << "start_time must be in [0, 1e10) seconds (got " << start_time << ")";
  } else if (motion != SynthMotion::kXyz && motion != SynthMotion::kRpy &&
             motion != SynthMotion::kHalfsphere && motion != SynthMotion::kStatic && motion != SynthMotion::kLoop) {
    msg << "motion must be one of xyz, rpy, halfsphere, static, loop (got " << static_cast<int>(motion) << ")";
  } else if (num_walkers < 0 || num_walkers > 4) {
    msg << "num_walkers must be in [0, 4] (got " << num_walkers << ")";
  } else if (!(finite(walker_speed) && walker_speed >= 0.2 && walker_speed <= 3.0)) {
    msg << "walker_speed must be in [0.2, 3] m/s (got " << walker_speed << ")";
  } else if (!(finite(max_coverage) && max_coverage > 0.0 && max_coverage <= 1.0)) {
    msg << "max_coverage must be in (0, 1] (got " << max_coverage << ")";
  } else if (!(finite(depth_min) && depth_min >= 0.0)) {
    msg << "depth_min must be finite and >= 0 m (got " << depth_min << ")";
  } else if (!(finite(depth_max) && depth_max > depth_min)) {
    msg << "depth_max must be finite and > depth_min (got " << depth_max << ", depth_min " << depth_min
        << ")";
  } else if (!(finite(depth_dropout) && depth_dropout >= 0.0 && depth_dropout < 1.0)) {
    msg << "depth_dropout must be in [0, 1) (got " << depth_dropout << ")";
  } else if (!(finite(depth_factor) && depth_factor > 0.0)) {
    msg << "depth_factor must be finite and > 0 (got " << depth_factor << ")";
  } else if (!(finite(fx) && fx >= 0.0)) {
    msg << "fx must be finite and >= 0 (0 = default; got " << fx << ")";
  } else if (!(finite(fy) && fy >= 0.0)) {
    msg << "fy must be finite and >= 0 (0 = default; got " << fy << ")";
  } else if (!finite(cx)) {
    msg << "cx must be finite (got " << cx << ")";
  } else if (!finite(cy)) {
    msg << "cy must be finite (got " << cy << ")";
  }
  if (msg.str().empty()) return true;
  if (error != nullptr) *error = msg.str();
  return false;
}

void SynthOptions::Validate() const {
  std::string error;
  DYPHO_CHECK_INPUT(IsValid(&error)) << "synthetic sequence options: " << error;
}

Camera SynthOptions::MakeCamera() const {
  // Kinect v1 / TUM default intrinsics at 640x480, scaled with the width
  // (square pixels; other aspect ratios change the vertical field of view),
  // principal point at the image centre (pixel centres at integers).
  const double scale = width / 640.0;
  Camera camera;
  camera.width = width;
  camera.height = height;
  camera.fx = fx > 0.0 ? fx : 525.0 * scale;
  camera.fy = fy > 0.0 ? fy : 525.0 * scale;
  camera.cx = cx != 0.0 ? cx : 0.5 * width - 0.5;
  camera.cy = cy != 0.0 ? cy : 0.5 * height - 0.5;
  return camera;
}

double SynthOptions::Timestamp(int index) const { return std::round((start_time + index / fps) * 1e6) / 1e6; }

}  // namespace dypho
