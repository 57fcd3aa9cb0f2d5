#include "engine/export/ply.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "common/check.h"
#include "common/files.h"
#include "engine/export/cloud_checks.h"
#include "engine/export/ply_header.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the PLY writer assumes a little-endian host");

namespace dypho {
namespace {

using export_internal::PlyElement;
using export_internal::PlyFormat;
using export_internal::PlyHeader;
using export_internal::PlyProperty;

// Canonical slots of the 3DGS vertex: where each property's value goes.
constexpr int kSlotX = 0;        // x y z
constexpr int kSlotDc = 3;       // f_dc_0..2
constexpr int kSlotRest = 6;     // f_rest_0..44
constexpr int kMaxRest = 45;
constexpr int kSlotOpacity = kSlotRest + kMaxRest;  // 51
constexpr int kSlotScale = kSlotOpacity + 1;        // scale_0..2
constexpr int kSlotRot = kSlotScale + 3;            // rot_0..3
constexpr int kNumSlots = kSlotRot + 4;             // 59

// Parses "<prefix><index>" with a decimal index in [0, limit); -1 otherwise.
int IndexedName(const std::string& name, const char* prefix, int limit) {
  const size_t len = std::strlen(prefix);
  if (name.size() <= len || name.compare(0, len, prefix) != 0) return -1;
  int value = 0;
  for (size_t i = len; i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9' || value > 1000) return -1;
    value = value * 10 + (name[i] - '0');
  }
  if (name.size() > len + 1 && name[len] == '0') return -1;  // no leading zeros
  return value < limit ? value : -1;
}

int SlotOf(const std::string& name) {
  if (name == "x") return kSlotX;
  if (name == "y") return kSlotX + 1;
  if (name == "z") return kSlotX + 2;
  if (name == "opacity") return kSlotOpacity;
  int i;
  if ((i = IndexedName(name, "f_dc_", 3)) >= 0) return kSlotDc + i;
  if ((i = IndexedName(name, "f_rest_", kMaxRest)) >= 0) return kSlotRest + i;
  if ((i = IndexedName(name, "scale_", 3)) >= 0) return kSlotScale + i;
  if ((i = IndexedName(name, "rot_", 4)) >= 0) return kSlotRot + i;
  return -1;
}

std::string SlotName(int slot) {
  static const char* kXyz[] = {"x", "y", "z"};
  if (slot < kSlotDc) return kXyz[slot];
  if (slot < kSlotRest) return "f_dc_" + std::to_string(slot - kSlotDc);
  if (slot < kSlotOpacity) return "f_rest_" + std::to_string(slot - kSlotRest);
  if (slot == kSlotOpacity) return "opacity";
  if (slot < kSlotRot) return "scale_" + std::to_string(slot - kSlotScale);
  return "rot_" + std::to_string(slot - kSlotRot);
}

struct VertexField {
  const PlyProperty* property;
  int slot;
};

// Which properties feed which slots; checks that every required one is there
// and that f_rest is 0, 9, 24 or 45 consecutive coefficients. Returns K.
int MapVertexFields(const std::string& path, const PlyElement& vertex, std::vector<VertexField>* fields) {
  std::vector<int> seen(kNumSlots, 0);
  for (const PlyProperty& p : vertex.properties) {
    const int slot = SlotOf(p.name);
    if (slot < 0) continue;
    DYPHO_CHECK_INPUT(!p.is_list) << path << ": vertex property '" << p.name << "' is a list, expected a scalar";
    DYPHO_CHECK_INPUT(!seen[slot]) << path << ": vertex property '" << p.name << "' appears twice";
    seen[slot] = 1;
    fields->push_back({&p, slot});
  }
  std::string missing;
  for (int slot = 0; slot < kNumSlots; ++slot) {
    if (slot >= kSlotRest && slot < kSlotOpacity) continue;
    if (!seen[slot]) missing += (missing.empty() ? "" : " ") + SlotName(slot);
  }
  DYPHO_CHECK_INPUT(missing.empty()) << path << ": not a 3D Gaussian splatting PLY: vertex element lacks the "
                                     << "required properties: " << missing;
  int rest = 0;
  while (rest < kMaxRest && seen[kSlotRest + rest]) ++rest;
  for (int j = rest; j < kMaxRest; ++j) {
    DYPHO_CHECK_INPUT(!seen[kSlotRest + j])
        << path << ": f_rest properties are not consecutive (f_rest_" << j << " present, f_rest_" << rest
        << " missing)";
  }
  DYPHO_CHECK_INPUT(rest == 0 || rest == 9 || rest == 24 || rest == 45)
      << path << ": " << rest << " f_rest properties; expected 0, 9, 24 or 45 (SH degree 0..3)";
  return 1 + rest / 3;
}

void CheckFinite(const std::string& path, float value, uint64_t vertex, const PlyProperty& p) {
  DYPHO_CHECK_INPUT(std::isfinite(value))
      << path << ": vertex " << vertex << " property '" << p.name << "' is " << value
      << " (NaN and infinite values are rejected)";
}

// Moves one decoded vertex into the cloud.
void Scatter(const float* v, int k, int64_t i, GaussianCloud* cloud) {
  std::memcpy(&cloud->means[3 * i], v + kSlotX, 3 * sizeof(float));
  std::memcpy(&cloud->log_scales[3 * i], v + kSlotScale, 3 * sizeof(float));
  std::memcpy(&cloud->quats[4 * i], v + kSlotRot, 4 * sizeof(float));
  cloud->opacity_logits[i] = v[kSlotOpacity];
  float* sh = &cloud->sh[static_cast<size_t>(i) * k * 3];
  for (int c = 0; c < 3; ++c) {
    sh[c] = v[kSlotDc + c];
    for (int j = 1; j < k; ++j) sh[j * 3 + c] = v[kSlotRest + c * (k - 1) + (j - 1)];
  }
}

void Resize(GaussianCloud* cloud, size_t n) {
  cloud->means.resize(3 * n);
  cloud->log_scales.resize(3 * n);
  cloud->quats.resize(4 * n);
  cloud->opacity_logits.resize(n);
  cloud->sh.resize(3 * cloud->sh_coeffs * n);
}

void ReadBinaryBody(const std::string& path, const std::string& data, const PlyHeader& header, int vertex_index,
                    const std::vector<VertexField>& fields, GaussianCloud* cloud) {
  size_t offset = header.body_offset;
  const size_t size = data.size();
  // Elements before the vertex element are skipped; they must be fixed-size.
  for (int e = 0; e < vertex_index; ++e) {
    const PlyElement& el = header.elements[e];
    DYPHO_CHECK_INPUT(el.FixedStride() > 0)
        << path << ": element '" << el.name << "' before 'vertex' has list properties (not supported)";
    DYPHO_CHECK_INPUT(el.count <= (size - offset) / el.FixedStride())
        << path << ": truncated: body ends inside element '" << el.name << "'";
    offset += el.count * el.FixedStride();
  }
  const PlyElement& vertex = header.elements[vertex_index];
  const size_t stride = vertex.FixedStride();
  DYPHO_CHECK_INPUT(stride > 0) << path << ": vertex element has list properties (not supported)";
  const uint64_t available = (size - offset) / stride;
  DYPHO_CHECK_INPUT(vertex.count <= available)
      << path << ": truncated: the header declares " << vertex.count << " vertices of " << stride
      << " bytes but the body holds " << size - offset << " bytes (vertex " << available << " is incomplete)";
  const int k = cloud->sh_coeffs;
  Resize(cloud, vertex.count);
  float v[kNumSlots];
  for (uint64_t i = 0; i < vertex.count; ++i) {
    const char* record = data.data() + offset + i * stride;
    for (const VertexField& f : fields) {
      if (f.property->type == export_internal::PlyType::kFloat32) {  // the common case, inline
        std::memcpy(&v[f.slot], record + f.property->offset, sizeof(float));
      } else {
        v[f.slot] = f.property->ReadBinary(record + f.property->offset);
      }
      if (!std::isfinite(v[f.slot])) CheckFinite(path, v[f.slot], i, *f.property);
    }
    Scatter(v, k, static_cast<int64_t>(i), cloud);
  }
  offset += vertex.count * stride;
  // Later elements: when all are fixed-size, the body must end exactly after
  // them; a mismatch means the header's counts are wrong.
  size_t expected_rest = 0;
  for (size_t e = vertex_index + 1; e < header.elements.size(); ++e) {
    const PlyElement& el = header.elements[e];
    if (el.FixedStride() == 0) return;  // list elements: sizes unknown without parsing
    DYPHO_CHECK_INPUT(el.count <= (size - offset - expected_rest) / el.FixedStride())
        << path << ": truncated: body ends inside element '" << el.name << "'";
    expected_rest += el.count * el.FixedStride();
  }
  DYPHO_CHECK_INPUT(offset + expected_rest == size)
      << path << ": " << size - offset - expected_rest << " bytes after the last element; the header declares "
      << vertex.count << " vertices, which does not match the body";
}

void ReadAsciiBody(const std::string& path, const std::string& data, const PlyHeader& header, int vertex_index,
                   const std::vector<VertexField>& fields, GaussianCloud* cloud) {
  const char* cursor = data.c_str() + header.body_offset;
  auto next_token = [&](std::string* token) {
    while (*cursor == ' ' || *cursor == '\t' || *cursor == '\r' || *cursor == '\n') ++cursor;
    const char* start = cursor;
    while (*cursor != '\0' && *cursor != ' ' && *cursor != '\t' && *cursor != '\r' && *cursor != '\n') ++cursor;
    token->assign(start, cursor);
    return cursor != start;
  };
  std::string token;
  auto skip_instance = [&](const PlyElement& el) {
    for (const PlyProperty& p : el.properties) {
      DYPHO_CHECK_INPUT(next_token(&token)) << path << ": truncated: body ends inside element '" << el.name << "'";
      if (!p.is_list) continue;
      char* end = nullptr;
      const long n = std::strtol(token.c_str(), &end, 10);
      DYPHO_CHECK_INPUT(*end == '\0' && n >= 0) << path << ": bad list length '" << token << "' in '" << el.name << "'";
      for (long j = 0; j < n; ++j) {
        DYPHO_CHECK_INPUT(next_token(&token)) << path << ": truncated: body ends inside element '" << el.name << "'";
      }
    }
  };
  for (int e = 0; e < vertex_index; ++e) {
    for (uint64_t i = 0; i < header.elements[e].count; ++i) skip_instance(header.elements[e]);
  }
  const PlyElement& vertex = header.elements[vertex_index];
  DYPHO_CHECK_INPUT(vertex.FixedStride() > 0) << path << ": vertex element has list properties (not supported)";
  // An ASCII value takes at least two characters, which bounds the count
  // before anything is allocated.
  const size_t body = data.size() - header.body_offset;
  DYPHO_CHECK_INPUT(vertex.count <= body / (2 * vertex.properties.size()) + 1)
      << path << ": truncated: the header declares " << vertex.count << " vertices but the ASCII body has only "
      << body << " bytes";
  std::vector<int> slot_of(vertex.properties.size(), -1);
  for (const VertexField& f : fields) slot_of[f.property - vertex.properties.data()] = f.slot;
  const int k = cloud->sh_coeffs;
  Resize(cloud, vertex.count);
  float v[kNumSlots];
  for (uint64_t i = 0; i < vertex.count; ++i) {
    for (size_t j = 0; j < vertex.properties.size(); ++j) {
      const PlyProperty& p = vertex.properties[j];
      DYPHO_CHECK_INPUT(next_token(&token))
          << path << ": truncated: the header declares " << vertex.count << " vertices but the body ends in vertex "
          << i;
      if (slot_of[j] < 0) continue;
      char* end = nullptr;
      const float value = std::strtof(token.c_str(), &end);
      DYPHO_CHECK_INPUT(*end == '\0') << path << ": vertex " << i << " property '" << p.name << "': '" << token
                                      << "' is not a number";
      CheckFinite(path, value, i, p);
      v[slot_of[j]] = value;
    }
    Scatter(v, k, static_cast<int64_t>(i), cloud);
  }
  for (size_t e = vertex_index + 1; e < header.elements.size(); ++e) {
    for (uint64_t i = 0; i < header.elements[e].count; ++i) skip_instance(header.elements[e]);
  }
  DYPHO_CHECK_INPUT(!next_token(&token))
      << path << ": values after the last element ('" << token << "'); the header declares " << vertex.count
      << " vertices, which does not match the body";
}

}  // namespace

void SavePly(const GaussianCloud& cloud, const std::string& path) {
  export_internal::CheckCloudForExport(cloud, path);
  const int n = cloud.size();
  const int k = cloud.sh_coeffs;
  const int rest = 3 * (k - 1);
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\nelement vertex " << n << "\n";
  for (const char* name : {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"}) {
    header << "property float " << name << "\n";
  }
  for (int j = 0; j < rest; ++j) header << "property float f_rest_" << j << "\n";
  for (const char* name : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"}) {
    header << "property float " << name << "\n";
  }
  header << "end_header\n";
  const std::string header_text = header.str();
  const int floats_per_vertex = 6 + 3 + rest + 1 + 3 + 4;

  WriteFileAtomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    DYPHO_CHECK_INPUT(out.good()) << "cannot open " << tmp << " for writing";
    out.write(header_text.data(), static_cast<std::streamsize>(header_text.size()));
    constexpr int kChunk = 16384;  // vertices per write
    std::vector<float> buffer(static_cast<size_t>(kChunk) * floats_per_vertex);
    for (int begin = 0; begin < n; begin += kChunk) {
      const int end = std::min(n, begin + kChunk);
      float* o = buffer.data();
      for (int i = begin; i < end; ++i) {
        const float* sh = &cloud.sh[static_cast<size_t>(i) * k * 3];
        *o++ = cloud.means[3 * i];
        *o++ = cloud.means[3 * i + 1];
        *o++ = cloud.means[3 * i + 2];
        *o++ = 0.0f;
        *o++ = 0.0f;
        *o++ = 0.0f;
        for (int c = 0; c < 3; ++c) *o++ = sh[c];
        for (int c = 0; c < 3; ++c) {
          for (int j = 1; j < k; ++j) *o++ = sh[j * 3 + c];
        }
        *o++ = cloud.opacity_logits[i];
        for (int j = 0; j < 3; ++j) *o++ = cloud.log_scales[3 * i + j];
        for (int j = 0; j < 4; ++j) *o++ = cloud.quats[4 * i + j];
      }
      out.write(reinterpret_cast<const char*>(buffer.data()),
                static_cast<std::streamsize>((o - buffer.data()) * sizeof(float)));
    }
    out.close();
    DYPHO_CHECK_INPUT(out.good()) << "error writing " << tmp;
  });
}

GaussianCloud LoadPly(const std::string& path) {
  DYPHO_CHECK_INPUT(std::filesystem::is_regular_file(path)) << "cannot open " << path << ": no such file";
  const std::string data = export_internal::ReadWholeFile(path);
  const PlyHeader header = export_internal::ParsePlyHeader(data, path);
  DYPHO_CHECK_INPUT(header.format != PlyFormat::kBinaryBigEndian)
      << path << ": binary_big_endian PLY is not supported (write it as binary_little_endian)";
  int vertex_index = -1;
  for (size_t e = 0; e < header.elements.size(); ++e) {
    if (header.elements[e].name == "vertex") vertex_index = static_cast<int>(e);
  }
  DYPHO_CHECK_INPUT(vertex_index >= 0) << path << ": no 'vertex' element in the header";
  DYPHO_CHECK_INPUT(header.elements[vertex_index].count <= static_cast<uint64_t>(INT32_MAX))
      << path << ": vertex count " << header.elements[vertex_index].count << " is too large";
  std::vector<VertexField> fields;
  GaussianCloud cloud;
  cloud.sh_coeffs = MapVertexFields(path, header.elements[vertex_index], &fields);
  if (header.format == PlyFormat::kAscii) {
    ReadAsciiBody(path, data, header, vertex_index, fields, &cloud);
  } else {
    ReadBinaryBody(path, data, header, vertex_index, fields, &cloud);
  }
  return cloud;
}

}  // namespace dypho
