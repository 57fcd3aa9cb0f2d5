// Keyframes waiting for the mapper: none is ever dropped.
//
// When mapping is slower than the camera, keyframes wait here until the
// mapping thread takes them (first in, first out). The first `raw_capacity`
// waiting keyframes stay as they are; a keyframe that arrives while that
// many wait is packed (PNG-compressed colour, 16-bit depth and mask:
// lossless for the TUM depth encoding, about a quarter of the raw size), and
// once the packed ones take more than `memory_limit_bytes` it is written to
// a file in `spill_dir` instead (read back and deleted when its turn
// comes). Without a spill folder, Put reports that the store is full and the
// caller waits (engine/api.cc blocks the pushing thread: slower, but nothing
// is lost).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "engine/map/mapper.h"

namespace dypho {

struct KeyframeStoreOptions {
  int raw_capacity = 4;                            // newest waiting keyframes kept unpacked
  size_t memory_limit_bytes = size_t{512} << 20;   // packed keyframes in memory beyond this go to spill_dir
  std::string spill_dir;                           // folder for spilled keyframes ("" = none: Put waits)
  void Validate() const;                           // throws InvalidInput naming the field
};

// A keyframe in compact form (exposed for tests).
struct PackedKeyframe {
  double timestamp = 0.0;
  Rigid3d cam_from_world;
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  std::vector<KeyframeFeature> features;
  int width = 0, height = 0;
  float depth_factor = 0.0f;         // depth units per metre of the 16-bit depth PNG
  std::vector<uint8_t> rgb_png;      // 8-bit RGB PNG
  std::vector<uint8_t> depth_png;    // 16-bit depth PNG; empty without depth
  std::vector<uint8_t> mask_png;     // 8-bit mask PNG; empty without mask
  std::vector<uint8_t> right_png;    // 8-bit RGB PNG of KeyframeInput::right_rgb; empty without it
  size_t bytes() const { return rgb_png.size() + depth_png.size() + mask_png.size() + right_png.size(); }
};

// Lossless for colour and mask; depth is rounded to 1 / depth_factor m
// (1/5000 m, the TUM encoding, up to 13.1 m; coarser for farther depths).
PackedKeyframe PackKeyframe(const KeyframeInput& input);
KeyframeInput UnpackKeyframe(const PackedKeyframe& packed);

struct KeyframeStoreStats {
  int waiting = 0;          // keyframes in the store
  int packed = 0;           // of them packed in memory
  int spilled = 0;          // of them in spill files
  size_t packed_bytes = 0;  // memory of the packed ones
  int total_packed = 0;     // keyframes ever packed (mapped late)
  int total_spilled = 0;    // keyframes ever spilled
  size_t peak_packed_bytes = 0;
};

class KeyframeStore {
 public:
  explicit KeyframeStore(const KeyframeStoreOptions& options);
  ~KeyframeStore();  // removes this store's spill files
  KeyframeStore(const KeyframeStore&) = delete;
  KeyframeStore& operator=(const KeyframeStore&) = delete;

  // Adds a keyframe with the caller's id. Returns false (and keeps nothing)
  // when memory is full and there is no spill folder: the caller must wait
  // for Take and try again.
  bool Put(int id, KeyframeInput input);
  bool empty() const { return items_.empty(); }
  int size() const { return static_cast<int>(items_.size()); }
  // The oldest keyframe, unpacked. The store must not be empty.
  std::pair<int, KeyframeInput> Take();
  // The pose of a waiting keyframe, or false when `id` is not waiting.
  bool SetPose(int id, const Rigid3d& cam_from_world);
  bool GetPose(int id, Rigid3d* cam_from_world) const;
  KeyframeStoreStats stats() const;

 private:
  struct Item;
  KeyframeStoreOptions options_;
  std::deque<std::unique_ptr<Item>> items_;
  KeyframeStoreStats stats_;
  std::string spill_prefix_;
  long spill_counter_ = 0;
};

}  // namespace dypho
