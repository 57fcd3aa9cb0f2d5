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
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/camera.h"
#include "engine/api.h"
#include "masking/segmenter.h"

namespace dypho {

class KeyframeDetection {
 public:
  // `options`: the segmenter's options at the masks' resolution (pixel sizes
  // already scaled); frames come at `camera`'s size and are reduced by the
  // integer `mask_downscale` before segmentation.
  KeyframeDetection(const SegmenterOptions& options, const Camera& camera, int mask_downscale);
  ~KeyframeDetection();

  // Records a pushed frame: its image name (for a PNG-folder segmenter) and
  // whether its semantic mask was fresh (the detector ran on it).
  void Note(double timestamp, const std::string& name, bool fresh);
  // The engine emitted the keyframe of the frame noted at `timestamp`: its
  // note is kept until operator() asks about it.
  void Claim(double timestamp);
  // EngineOptions::keyframe_mask: empty for a frame with a fresh mask or one
  // never noted; else the fresh segmentation at the camera's size.
  std::vector<uint8_t> operator()(const KeyframeMaskRequest& request);
  int runs() const;  // segmentations run so far

 private:
  struct Noted {
    std::string name;
    bool fresh = false;
  };
  std::unique_ptr<Segmenter> segmenter_;
  Camera camera_;
  int downscale_ = 1;
  mutable std::mutex mutex_;  // notes and runs_
  std::mutex segment_mutex_;  // segmenter_
  std::map<double, Noted> noted_;  // the most recent frames (a keyframe is at most a window old)
  std::map<double, Noted> claimed_;  // keyframes not asked about yet
  int runs_ = 0;
};

}  // namespace dypho
