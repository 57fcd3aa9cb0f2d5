#include "engine/map/keyframe_store.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>


#include "common/check.h"
#include "common/files.h"
#include "engine/io/image_io.h"
#include "engine/io/png_encode.h"

namespace dypho {

void KeyframeStoreOptions::Validate() const {
  DYPHO_CHECK_INPUT(raw_capacity >= 0) << "keyframe store raw_capacity must be >= 0 (got " << raw_capacity << ")";
  DYPHO_CHECK_INPUT(memory_limit_bytes >= (size_t{1} << 20))
      << "keyframe store memory limit must be at least 1 MiB (got " << memory_limit_bytes << " bytes)";
}

namespace {

// Our PNG encoder (Sub filter, libdeflate level 1: 3x faster than
// cv::imencode at level 1, the same size); read back by image_io's decoders
// (ours, OpenCV for anything ours does not read).
std::vector<uint8_t> EncodePng(const ImageU8& image) {
  return EncodePng8(image.data(), image.width(), image.height(), image.channels());
}

// A decoded packed image must have the keyframe's size.
template <typename T>
Image<T> Sized(Image<T> image, int width, int height) {
  DYPHO_CHECK(image.width() == width && image.height() == height) << "a packed keyframe image has the wrong size";
  return image;
}

// Spill files: a small binary record of the packed keyframe.
constexpr char kSpillMagic[8] = {'D', 'Y', 'K', 'F', 'S', 'P', 'L', '3'};

template <typename T>
void Put(std::ofstream& out, const T& v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof(T));
}
template <typename T>
void Get(std::ifstream& in, T* v) {
  in.read(reinterpret_cast<char*>(v), sizeof(T));
}
void PutBytes(std::ofstream& out, const std::vector<uint8_t>& b) {
  Put(out, static_cast<uint64_t>(b.size()));
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}
void GetBytes(std::ifstream& in, std::vector<uint8_t>* b, const std::string& path) {
  uint64_t n = 0;
  Get(in, &n);
  DYPHO_CHECK(in && n < (uint64_t{1} << 32)) << "spill file " << path << " is damaged";
  b->resize(n);
  in.read(reinterpret_cast<char*>(b->data()), static_cast<std::streamsize>(n));
}

void WriteSpill(const std::string& path, const PackedKeyframe& p) {
  WriteFileAtomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    DYPHO_CHECK_INPUT(out.good()) << "cannot write the spilled keyframe " << tmp;
    out.write(kSpillMagic, sizeof(kSpillMagic));
    Put(out, p.timestamp);
    const Eigen::Quaterniond& q = p.cam_from_world.rotation;
    for (double v : {q.w(), q.x(), q.y(), q.z()}) Put(out, v);
    for (int i = 0; i < 3; ++i) Put(out, p.cam_from_world.translation[i]);
    for (int i = 0; i < 3; ++i) Put(out, p.angular_velocity[i]);
    Put(out, static_cast<int32_t>(p.width));
    Put(out, static_cast<int32_t>(p.height));
    Put(out, p.depth_factor);
    Put(out, static_cast<uint64_t>(p.features.size()));
    for (const KeyframeFeature& f : p.features) {
      Put(out, f.x);
      Put(out, f.y);
      Put(out, f.depth);
    }
    PutBytes(out, p.rgb_png);
    PutBytes(out, p.depth_png);
    PutBytes(out, p.mask_png);
    PutBytes(out, p.right_png);
    out.flush();
    DYPHO_CHECK_INPUT(out.good()) << "cannot write the spilled keyframe " << tmp << " (disk full?)";
  });
}

PackedKeyframe ReadSpill(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  DYPHO_CHECK(in.good()) << "spill file " << path << " is gone";
  char magic[8];
  in.read(magic, sizeof(magic));
  DYPHO_CHECK(in && std::memcmp(magic, kSpillMagic, sizeof(magic)) == 0) << "spill file " << path << " is damaged";
  PackedKeyframe p;
  Get(in, &p.timestamp);
  double q[4];
  for (double& v : q) Get(in, &v);
  p.cam_from_world.rotation = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
  for (int i = 0; i < 3; ++i) Get(in, &p.cam_from_world.translation[i]);
  for (int i = 0; i < 3; ++i) Get(in, &p.angular_velocity[i]);
  int32_t w = 0, h = 0;
  Get(in, &w);
  Get(in, &h);
  p.width = w;
  p.height = h;
  Get(in, &p.depth_factor);
  uint64_t n = 0;
  Get(in, &n);
  DYPHO_CHECK(in && n < (uint64_t{1} << 24)) << "spill file " << path << " is damaged";
  p.features.resize(n);
  for (KeyframeFeature& f : p.features) {
    Get(in, &f.x);
    Get(in, &f.y);
    Get(in, &f.depth);
  }
  GetBytes(in, &p.rgb_png, path);
  GetBytes(in, &p.depth_png, path);
  GetBytes(in, &p.mask_png, path);
  GetBytes(in, &p.right_png, path);
  DYPHO_CHECK(in.good()) << "spill file " << path << " is damaged";
  return p;
}

}  // namespace

PackedKeyframe PackKeyframe(const KeyframeInput& input) {
  PackedKeyframe p;
  p.timestamp = input.timestamp;
  p.cam_from_world = input.cam_from_world;
  p.angular_velocity = input.angular_velocity;
  p.features = input.features;
  p.width = input.rgb.width();
  p.height = input.rgb.height();
  p.rgb_png = EncodePng(input.rgb);
  if (!input.depth.empty()) {
    float max_depth = 0.0f;
    for (float d : input.depth.pixels()) {
      if (std::isfinite(d)) max_depth = std::max(max_depth, d);
    }
    p.depth_factor = std::min(5000.0f, 65535.0f / std::max(1e-3f, max_depth));
    std::vector<uint16_t> depth16(input.depth.size());
    for (size_t i = 0; i < depth16.size(); ++i) {
      const float d = input.depth.data()[i];
      depth16[i] = std::isfinite(d) && d > 0 ? static_cast<uint16_t>(std::min(65535.0f, std::round(d * p.depth_factor))) : 0;
    }
    p.depth_png = EncodePng16(depth16.data(), input.depth.width(), input.depth.height());
  }
  if (!input.dynamic_mask.empty()) p.mask_png = EncodePng(input.dynamic_mask);
  if (!input.right_rgb.empty()) p.right_png = EncodePng(input.right_rgb);
  return p;
}

KeyframeInput UnpackKeyframe(const PackedKeyframe& p) {
  KeyframeInput in;
  in.timestamp = p.timestamp;
  in.cam_from_world = p.cam_from_world;
  in.angular_velocity = p.angular_velocity;
  in.features = p.features;
  in.rgb = Sized(DecodeRgb8(p.rgb_png, "a packed keyframe's colour"), p.width, p.height);
  if (!p.depth_png.empty()) {
    const Image<uint16_t> d16 = Sized(DecodeDepth16(p.depth_png, "a packed keyframe's depth"), p.width, p.height);
    in.depth = ImageF(p.width, p.height, 1);
    for (size_t i = 0; i < d16.size(); ++i) in.depth.data()[i] = d16.data()[i] / p.depth_factor;
  }
  if (!p.mask_png.empty()) in.dynamic_mask = Sized(DecodeGray8(p.mask_png, "a packed keyframe's mask"), p.width, p.height);
  if (!p.right_png.empty()) in.right_rgb = Sized(DecodeRgb8(p.right_png, "a packed keyframe's right image"), p.width, p.height);
  return in;
}

struct KeyframeStore::Item {
  int id = -1;
  std::optional<KeyframeInput> raw;
  std::optional<PackedKeyframe> packed;
  std::string spill_path;
  Rigid3d pose;  // the current pose (a correction may arrive while it waits)
};

KeyframeStore::KeyframeStore(const KeyframeStoreOptions& options) : options_(options) {
  options.Validate();
  if (!options.spill_dir.empty()) {
    MakeDirectories(options.spill_dir);
    spill_prefix_ = (std::filesystem::path(options.spill_dir) / ("keyframe_" + std::to_string(getpid()) + "_")).string();
  }
}

KeyframeStore::~KeyframeStore() {
  std::error_code ignored;
  for (const auto& item : items_) {
    if (!item->spill_path.empty()) std::filesystem::remove(item->spill_path, ignored);
  }
  if (!options_.spill_dir.empty()) std::filesystem::remove(options_.spill_dir, ignored);  // only when empty
}

bool KeyframeStore::Put(int id, KeyframeInput input) {
  auto item = std::make_unique<Item>();
  item->id = id;
  item->pose = input.cam_from_world;
  int raw = 0;
  for (const auto& i : items_) raw += i->raw.has_value();
  if (raw < options_.raw_capacity) {
    item->raw = std::move(input);
  } else {
    PackedKeyframe packed = PackKeyframe(input);
    if (stats_.packed_bytes + packed.bytes() <= options_.memory_limit_bytes) {
      stats_.packed_bytes += packed.bytes();
      stats_.peak_packed_bytes = std::max(stats_.peak_packed_bytes, stats_.packed_bytes);
      item->packed = std::move(packed);
      ++stats_.packed;
      ++stats_.total_packed;
    } else if (!spill_prefix_.empty()) {
      item->spill_path = spill_prefix_ + std::to_string(spill_counter_++) + ".bin";
      WriteSpill(item->spill_path, packed);
      ++stats_.spilled;
      ++stats_.total_packed;
      ++stats_.total_spilled;
    } else {
      return false;
    }
  }
  items_.push_back(std::move(item));
  ++stats_.waiting;
  return true;
}

std::pair<int, KeyframeInput> KeyframeStore::Take() {
  DYPHO_CHECK(!items_.empty()) << "KeyframeStore::Take on an empty store";
  std::unique_ptr<Item> item = std::move(items_.front());
  items_.pop_front();
  --stats_.waiting;
  KeyframeInput input;
  if (item->raw) {
    input = std::move(*item->raw);
  } else if (item->packed) {
    stats_.packed_bytes -= item->packed->bytes();
    --stats_.packed;
    input = UnpackKeyframe(*item->packed);
  } else {
    input = UnpackKeyframe(ReadSpill(item->spill_path));
    std::error_code ignored;
    std::filesystem::remove(item->spill_path, ignored);
    --stats_.spilled;
  }
  input.cam_from_world = item->pose;
  return {item->id, std::move(input)};
}

bool KeyframeStore::SetPose(int id, const Rigid3d& cam_from_world) {
  for (auto& item : items_) {
    if (item->id == id) {
      item->pose = cam_from_world;
      return true;
    }
  }
  return false;
}

bool KeyframeStore::GetPose(int id, Rigid3d* cam_from_world) const {
  for (const auto& item : items_) {
    if (item->id == id) {
      *cam_from_world = item->pose;
      return true;
    }
  }
  return false;
}

KeyframeStoreStats KeyframeStore::stats() const { return stats_; }

}  // namespace dypho
