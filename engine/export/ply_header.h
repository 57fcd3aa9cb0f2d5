// PLY header parsing (Turk's PLY format as documented by Paul Bourke,
// "PLY - Polygon File Format"): the part of the format every reader in
// engine/export shares. Internal to engine/export.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace dypho::export_internal {

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  // value type (for lists: the item type)
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;  // lists only
  size_t offset = 0;                     // byte offset in a fixed-size binary record

  // Decodes one little-endian value of `type` at `p` as float.
  float ReadBinary(const char* p) const;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
  // Bytes per binary record, or 0 when a property is a list.
  size_t FixedStride() const;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::kBinaryLittleEndian;
  std::vector<PlyElement> elements;
  size_t body_offset = 0;  // first byte after "end_header\n"
};

size_t PlyTypeSize(PlyType type);

// Parses the header at the start of `data`. Throws InvalidInput naming
// `path` when the file is not PLY or the header is malformed (unknown
// keyword or type, bad count, property outside an element, no end_header).
PlyHeader ParsePlyHeader(const std::string& data, const std::string& path);

}  // namespace dypho::export_internal
