#include "engine/synth/shore/shore_options.h"

#include <cmath>
#include <sstream>

#include "common/check.h"

namespace dypho {

bool ShoreSynthOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (width < 16) e << "width must be >= 16 (got " << width << ")";
  else if (height < 16) e << "height must be >= 16 (got " << height << ")";
  else if (frames < 1) e << "frames must be >= 1 (got " << frames << ")";
  else if (!(std::isfinite(fps) && fps > 0 && fps <= 1000)) e << "fps must be in (0, 1000] (got " << fps << ")";
  else if (!in(start_time, 0, 1e12)) e << "start_time must be in [0, 1e12] (got " << start_time << ")";
  else if (num_pedestrians < 0 || num_pedestrians > 6) e << "num_pedestrians must be in [0, 6] (got " << num_pedestrians << ")";
  else if (!in(boat_speed, 0.2, 10)) e << "boat_speed must be in [0.2, 10] m/s (got " << boat_speed << ")";
  else if (!in(boat_speed_own, 0, 5)) e << "boat_speed_own must be in [0, 5] m/s (got " << boat_speed_own << ")";
  else if (!in(roll_deg, 0, 20)) e << "roll_deg must be in [0, 20] (got " << roll_deg << ")";
  else if (!(std::isfinite(depth_max) && depth_max > 0)) e << "depth_max must be > 0 (got " << depth_max << ")";
  else if (!(std::isfinite(depth_factor) && depth_factor > 0)) e << "depth_factor must be > 0 (got " << depth_factor << ")";
  else if (!(std::isfinite(baseline) && baseline > 0 && baseline <= 2)) e << "baseline must be in (0, 2] m (got " << baseline << ")";
  else if (!(std::isfinite(focal) && focal >= 0)) e << "focal must be >= 0 (got " << focal << ")";
  if (e.str().empty()) return true;
  if (error) *error = e.str();
  return false;
}

void ShoreSynthOptions::Validate() const {
  std::string error;
  DYPHO_CHECK_INPUT(IsValid(&error)) << "shore sequence options: " << error;
}

Camera ShoreSynthOptions::MakeCamera() const {
  Camera camera;
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = focal > 0 ? focal : 262.5 * width / 320.0;
  camera.cx = 0.5 * width - 0.5;
  camera.cy = 0.5 * height - 0.5;
  return camera;
}

double ShoreSynthOptions::Timestamp(int index) const {
  return std::round((start_time + index / fps) * 1e6) / 1e6;
}

}  // namespace dypho
