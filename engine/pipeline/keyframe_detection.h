// The detector run again on keyframes (PipelineOptions::keyframe_detection).
//
// Between detector runs (masking.schedule.interval > 1, or the detector's
// own thread) the semantic mask is carried from the last run by the optical
// flow. A carried mask cannot show a person who came into view since that
// run (from the image border, or from behind another person), and during
// fast rotation the flow lags: on the walkers version of TUM fr1/rpy such a
// keyframe put a whole walker into the map even with the exact masks as the
// "detector" (interval 5). Keyframes decide what enters the map, so each
// keyframe whose mask was carried gets a fresh segmentation of its own
// frame, which joins its mask (Engine::keyframe_mask). One extra detector
// run per keyframe, on the engine's mapping thread just before the keyframe
// is mapped (engine/keyframe_masks.h): the tracking thread does not wait for
// it. The pipeline claims each keyframe it is told of (Claim), so that its
// note outlives the window of recent frames however late the mapping
// thread asks.
//
// The fresh segmentation is refined against the frame's own background
// depth B (masking/background_model.h, RefineMask) when the frame's B is
// given to Note: pixels of a box that agree with a supported background
// are static (the depth region of a box spills onto the desk or monitor a
// person stands at, and a false box covers static things). A person the
// carried mask missed is in front of B there and stays masked. Walkers
// version of TUM fr1/rpy, seed 7: the keyframes' masks without the
// refinement covered much of the static scene next to a standing walker
// (BENCHMARKS "Keyframe detections refined by the background").
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "engine/api.h"
#include "masking/background_model.h"
#include "masking/segmenter.h"

namespace dypho {

class KeyframeDetection {
 public:
  // `options`: the segmenter's options at the masks' resolution (pixel sizes
  // already scaled); frames come at `camera`'s size and are reduced by the
  // integer `mask_downscale` before segmentation.
  // `refine`: the refinement's options (pixel sizes at the masks'
  // resolution; add_dynamic is not used: the frame's own mask has its
  // additions); nullopt = the fresh segmentation as it is.
  KeyframeDetection(const SegmenterOptions& options, const Camera& camera, int mask_downscale,
                    std::optional<BackgroundOptions> refine = std::nullopt);
  ~KeyframeDetection();

  // Records a pushed frame: its image name (for a PNG-folder segmenter),
  // whether its semantic mask was fresh (the detector ran on it), and its
  // background depth B and support S at the masks' resolution (both empty:
  // none; kept, shared and not copied, for the last kBackgroundFrames
  // frames: the caller must not write into them afterwards).
  void Note(double timestamp, const std::string& name, bool fresh, const cv::Mat& background = cv::Mat(),
            const cv::Mat& support = cv::Mat());
  // The engine emitted the keyframe of the frame noted at `timestamp`: its
  // note is kept until operator() asks about it.
  void Claim(double timestamp);
  // EngineOptions::keyframe_mask: empty for a frame with a fresh mask or one
  // never noted; else the fresh segmentation at the camera's size.
  std::vector<uint8_t> operator()(const KeyframeMaskRequest& request);
  int runs() const;  // segmentations run so far
  // Of them, refined against the frame's background, and the pixels the
  // refinement made static in all.
  int refined() const;
  long refined_pixels() const;

  // Recent frames whose background is kept: more than a keyframe candidate
  // can be old when it is emitted (kMaxSharpnessWindow).
  static constexpr size_t kBackgroundFrames = 32;

 private:
  struct Noted {
    std::string name;
    bool fresh = false;
    cv::Mat background;  // CV_32FC1 [m], 0 = unknown; empty = none (shared with the masker's result)
    cv::Mat support;     // CV_8UC1
  };
  std::unique_ptr<Segmenter> segmenter_;
  Camera camera_;
  int downscale_ = 1;
  std::optional<BackgroundOptions> refine_;
  mutable std::mutex mutex_;  // notes and runs_
  std::mutex segment_mutex_;  // segmenter_
  std::map<double, Noted> noted_;  // the most recent frames (a keyframe is at most a window old)
  std::map<double, Noted> claimed_;  // keyframes not asked about yet
  int runs_ = 0;
  int refined_ = 0;
  long refined_pixels_ = 0;
};

// EngineOptions::keyframe_mask of a run: the fresh detection of `detection`
// (may be null), and when `folder` is not empty every keyframe's final mask
// (the mask it was pushed with joined with that answer; camera size,
// distorted, 255 = left out of the map) written there as <timestamp>.png,
// the timestamp with 6 decimals (PipelineOptions::write_keyframe_masks).
std::function<std::vector<uint8_t>(const KeyframeMaskRequest&)> KeyframeMaskHook(
    std::shared_ptr<KeyframeDetection> detection, const std::string& folder);

}  // namespace dypho
