// FrameDepthPriorOptions::IsValid on its own: the options parser (and its
// fuzz target) needs it without the prior's OpenCV warps.
#include <cmath>
#include <sstream>

#include "engine/pipeline/frame_depth_prior.h"

namespace dypho {

bool FrameDepthPriorOptions::IsValid(std::string* error) const {
  std::ostringstream e;
  if (max_frames < 1 || max_frames > 1000)
    e << "max_frames must be in 1..1000 (got " << max_frames << ")";
  else if (fuse < 1 || fuse > max_frames)
    e << "fuse must be in 1..max_frames (" << max_frames << ") (got " << fuse << ")";
  else if (!(spacing >= 0.0 && std::isfinite(spacing)))
    e << "spacing must be >= 0 (got " << spacing << ")";
  else if (!(rotation_weight >= 0.0 && std::isfinite(rotation_weight)))
    e << "rotation_weight must be >= 0 (got " << rotation_weight << ")";
  else if (min_agree < 0 || min_agree >= fuse)
    e << "min_agree must be in 0..fuse-1 (got " << min_agree << ")";
  else if (!(tolerance_abs > 0.0 && std::isfinite(tolerance_abs)) || !(tolerance_rel >= 0.0 && std::isfinite(tolerance_rel)))
    e << "tolerance_abs must be > 0 and tolerance_rel >= 0";
  else if (mask_margin_px < 0 || mask_margin_px > 50)
    e << "mask_margin_px must be in 0..50 (got " << mask_margin_px << ")";
  else
    return true;
  if (error) *error = e.str();
  return false;
}

}  // namespace dypho
