#include "engine/export/ply_header.h"

#include <cstring>
#include <sstream>

#include "common/check.h"

namespace dypho::export_internal {
namespace {

bool ParseType(const std::string& s, PlyType* type) {
  // Both the original names and the sized aliases are in use.
  static const struct {
    const char* name;
    PlyType type;
  } kTypes[] = {{"char", PlyType::kInt8},     {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
                {"uint8", PlyType::kUint8},   {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
                {"ushort", PlyType::kUint16}, {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
                {"int32", PlyType::kInt32},   {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
                {"float", PlyType::kFloat32}, {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
                {"float64", PlyType::kFloat64}};
  for (const auto& t : kTypes) {
    if (s == t.name) {
      *type = t.type;
      return true;
    }
  }
  return false;
}

template <typename T>
float Read(const char* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return static_cast<float>(value);
}

}  // namespace

size_t PlyTypeSize(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

float PlyProperty::ReadBinary(const char* p) const {
  switch (type) {
    case PlyType::kInt8:
      return Read<int8_t>(p);
    case PlyType::kUint8:
      return Read<uint8_t>(p);
    case PlyType::kInt16:
      return Read<int16_t>(p);
    case PlyType::kUint16:
      return Read<uint16_t>(p);
    case PlyType::kInt32:
      return Read<int32_t>(p);
    case PlyType::kUint32:
      return Read<uint32_t>(p);
    case PlyType::kFloat32:
      return Read<float>(p);
    case PlyType::kFloat64:
      return Read<double>(p);
  }
  return 0.0f;
}

size_t PlyElement::FixedStride() const {
  size_t stride = 0;
  for (const PlyProperty& p : properties) {
    if (p.is_list) return 0;
    stride += PlyTypeSize(p.type);
  }
  return stride;
}

PlyHeader ParsePlyHeader(const std::string& data, const std::string& path) {
  DYPHO_CHECK_INPUT(data.compare(0, 4, "ply\n") == 0 || data.compare(0, 5, "ply\r\n") == 0)
      << path << ": not a PLY file (it does not start with the line 'ply')";
  PlyHeader header;
  bool have_format = false;
  size_t pos = 0;
  int line_no = 0;
  while (true) {
    const size_t eol = data.find('\n', pos);
    DYPHO_CHECK_INPUT(eol != std::string::npos) << path << ": PLY header has no 'end_header' line";
    std::string line = data.substr(pos, eol - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = eol + 1;
    ++line_no;
    if (line_no == 1) continue;  // "ply"
    std::istringstream in(line);
    std::string keyword;
    in >> keyword;
    if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") break;
    const std::string where = path + ": PLY header line " + std::to_string(line_no) + " '" + Printable(line) + "'";
    if (keyword == "format") {
      std::string format, version;
      in >> format >> version;
      if (format == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (format == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittleEndian;
      } else if (format == "binary_big_endian") {
        header.format = PlyFormat::kBinaryBigEndian;
      } else {
        DYPHO_CHECK_INPUT(false) << where << ": unknown format '" << Printable(format) << "'";
      }
      DYPHO_CHECK_INPUT(version == "1.0") << where << ": unsupported PLY version '" << version << "'";
      have_format = true;
    } else if (keyword == "element") {
      PlyElement element;
      std::string count;
      in >> element.name >> count;
      DYPHO_CHECK_INPUT(!element.name.empty() && !count.empty() &&
                        count.find_first_not_of("0123456789") == std::string::npos && count.size() < 19)
          << where << ": expected 'element NAME COUNT' with a non-negative integer count";
      element.count = std::stoull(count);
      header.elements.push_back(element);
    } else if (keyword == "property") {
      DYPHO_CHECK_INPUT(!header.elements.empty()) << where << ": property before any element";
      PlyElement& element = header.elements.back();
      PlyProperty p;
      std::string type;
      in >> type;
      if (type == "list") {
        std::string count_type, item_type;
        in >> count_type >> item_type >> p.name;
        p.is_list = true;
        DYPHO_CHECK_INPUT(ParseType(count_type, &p.count_type) && ParseType(item_type, &p.type))
            << where << ": unknown list type";
      } else {
        in >> p.name;
        DYPHO_CHECK_INPUT(ParseType(type, &p.type)) << where << ": unknown property type '" << Printable(type) << "'";
      }
      DYPHO_CHECK_INPUT(!p.name.empty()) << where << ": property without a name";
      // Offsets only matter for fixed-size records (no list in the element).
      if (!element.properties.empty()) {
        p.offset = element.properties.back().offset + PlyTypeSize(element.properties.back().type);
      }
      element.properties.push_back(p);
    } else {
      DYPHO_CHECK_INPUT(false) << where << ": unknown keyword '" << Printable(keyword) << "'";
    }
  }
  DYPHO_CHECK_INPUT(have_format) << path << ": PLY header has no 'format' line";
  header.body_offset = pos;
  // Every record takes some bytes of the body (binary: its fixed values and
  // list lengths; ASCII: at least one character per value), so the counts are
  // bounded by the file's size before anything loops over them. A record of
  // no properties would take none: 10^18 of them hung the ASCII reader. (The
  // readers check the vertex element and binary records themselves, with
  // messages naming the incomplete vertex: the bound here is for the ASCII
  // elements they skip.)
  uint64_t left = data.size() - pos;
  for (const PlyElement& element : header.elements) {
    DYPHO_CHECK_INPUT(element.count == 0 || !element.properties.empty())
        << path << ": PLY element '" << Printable(element.name) << "' declares " << element.count
        << " records but no properties";
    uint64_t min_bytes = 0;
    for (const PlyProperty& p : element.properties) {
      min_bytes += header.format == PlyFormat::kAscii ? 1 : PlyTypeSize(p.is_list ? p.count_type : p.type);
    }
    if (element.count == 0 || header.format != PlyFormat::kAscii || element.name == "vertex") continue;
    DYPHO_CHECK_INPUT(element.count <= left / min_bytes)
        << path << ": truncated or corrupt: the header declares " << element.count << " '" << Printable(element.name)
        << "' records of at least " << min_bytes << " bytes, but only " << left << " bytes of the body are left";
    left -= element.count * min_bytes;
  }
  return header;
}

}  // namespace dypho::export_internal
