// For fuzz_options only: the whole-component checks that PipelineOptions::
// Validate calls and that live with their component's code (OpenCV, the
// masker, the tracker). The fuzz target exercises the reading of YAML/JSON
// option files and each key's type and range; these cross-field checks are
// outside it and accept everything here.
#include <string>

#include "engine/map/keyframe_selector.h"
#include "masking/async_segmenter.h"
#include "masking/dynamic_masker.h"
#include "tracker/orb_tracker.h"

namespace dypho {
void KeyframePolicy::Validate() const {}
bool MaskingOptions::IsValid(std::string*) const { return true; }
bool OrbTrackerOptions::IsValid(std::string*) const { return true; }
// The mask-age check compares this lag with max_carry_frames: 0 passes.
int MaskLagForAge(int, int) { return 0; }
}  // namespace dypho
