#include "engine/export/spz.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/check.h"
#include "common/files.h"
#include "engine/export/cloud_checks.h"

namespace dypho {
namespace {

constexpr uint32_t kMagic = 0x5053474e;  // "NGSP" read as a little-endian uint32
constexpr size_t kHeaderBytes = 16;
constexpr uint8_t kFlagAntialiased = 0x1;
constexpr uint8_t kFlagExtensions = 0x2;
constexpr int kDefaultFractionalBits = 12;
constexpr double kColorScale = 0.15;
constexpr double kSqrt2 = 1.41421356237309504880;
constexpr int32_t kMaxFixed = (1 << 23) - 1;  // largest int24

// The frame change RDF <-> RUB flips y and z (see the header).
constexpr double kFlip[3] = {1.0, -1.0, -1.0};

struct Header {
  uint32_t magic = kMagic;
  uint32_t version = 3;
  uint32_t num_points = 0;
  uint8_t sh_degree = 0;
  uint8_t fractional_bits = kDefaultFractionalBits;
  uint8_t flags = 0;
  uint8_t reserved = 0;
};

void PutU32(uint8_t* out, uint32_t v) {
  for (int b = 0; b < 4; ++b) out[b] = static_cast<uint8_t>(v >> (8 * b));
}

uint32_t GetU32(const uint8_t* in) {
  return uint32_t(in[0]) | uint32_t(in[1]) << 8 | uint32_t(in[2]) << 16 | uint32_t(in[3]) << 24;
}

uint8_t ToByte(double v) { return static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L)); }

int ShDegree(int sh_coeffs) {
  for (int d = 0; d <= 3; ++d) {
    if ((d + 1) * (d + 1) == sh_coeffs) return d;
  }
  return -1;
}

// Bytes per point of each array.
size_t RotationBytes(uint32_t version) { return version >= 3 ? 4 : 3; }
size_t BodyBytes(uint32_t version, size_t n, int sh_degree) {
  const size_t sh = 3 * static_cast<size_t>((sh_degree + 1) * (sh_degree + 1) - 1);
  return n * (9 + 1 + 3 + 3 + RotationBytes(version) + sh);
}

// Largest fractional bits <= 12 with which every |coordinate| fits in int24.
int FractionalBits(const GaussianCloud& cloud, const std::string& what) {
  double max_abs = 0.0;
  for (float v : cloud.means) max_abs = std::max(max_abs, std::fabs(double(v)));
  for (int bits = kDefaultFractionalBits; bits >= 0; --bits) {
    if (std::round(max_abs * std::ldexp(1.0, bits)) <= kMaxFixed) return bits;
  }
  DYPHO_CHECK_INPUT(false) << what << ": a Gaussian lies " << max_abs
                           << " m from the origin; .spz positions (24-bit fixed point) reach at most " << kMaxFixed
                           << " m";
  return 0;
}

// Version 3: smallest three (see the header). `q` is x y z w, unit.
uint32_t PackSmallestThree(const double q[4]) {
  int largest = 0;
  for (int i = 1; i < 4; ++i) {
    if (std::fabs(q[i]) > std::fabs(q[largest])) largest = i;
  }
  const bool negate = q[largest] < 0;
  uint32_t packed = static_cast<uint32_t>(largest);
  for (int i = 0; i < 4; ++i) {
    if (i == largest) continue;
    const double v = negate ? -q[i] : q[i];
    const uint32_t magnitude = static_cast<uint32_t>(std::min(511L, std::lround(511.0 * std::fabs(v) * kSqrt2)));
    packed = (packed << 10) | (v < 0 ? 1u << 9 : 0u) | magnitude;
  }
  return packed;
}

void UnpackSmallestThree(uint32_t packed, double q[4]) {
  const int largest = static_cast<int>(packed >> 30);
  double sum_squares = 0.0;
  for (int i = 3; i >= 0; --i) {
    if (i == largest) continue;
    const double magnitude = (packed & 511u) / (511.0 * kSqrt2);
    q[i] = (packed & (1u << 9)) ? -magnitude : magnitude;
    sum_squares += q[i] * q[i];
    packed >>= 10;
  }
  q[largest] = std::sqrt(std::max(0.0, 1.0 - sum_squares));
}

// Inflates a gzip stream, refusing more than `limit` bytes of output (so a
// hostile header or stream cannot make it allocate more than the file
// implies). Stops after `limit` bytes when `stop_at_limit`.
std::vector<uint8_t> Gunzip(const uint8_t* data, size_t size, size_t limit, bool stop_at_limit,
                            const std::string& what, bool* ended) {
  z_stream stream{};
  DYPHO_CHECK_INPUT(inflateInit2(&stream, 16 + MAX_WBITS) == Z_OK) << what << ": zlib inflateInit2 failed";
  std::vector<uint8_t> out;
  uint8_t chunk[1 << 16];
  stream.next_in = const_cast<Bytef*>(data);
  size_t remaining_in = size;
  int status = Z_OK;
  std::string error;
  *ended = false;
  while (status != Z_STREAM_END) {
    if (stream.avail_in == 0 && remaining_in > 0) {
      const size_t take = std::min<size_t>(remaining_in, 1u << 30);
      stream.avail_in = static_cast<uInt>(take);
      remaining_in -= take;
    }
    stream.next_out = chunk;
    stream.avail_out = sizeof(chunk);
    status = inflate(&stream, Z_NO_FLUSH);
    if (status == Z_NEED_DICT || status == Z_DATA_ERROR || status == Z_MEM_ERROR) {
      error = std::string("corrupt compressed data (zlib: ") + (stream.msg ? stream.msg : "error") + ")";
      break;
    }
    const size_t produced = sizeof(chunk) - stream.avail_out;
    if (out.size() + produced > limit) {
      if (stop_at_limit) {
        out.insert(out.end(), chunk, chunk + (limit - out.size()));
        break;
      }
      error = "decompresses to more than the " + std::to_string(limit) + " bytes its header's point count implies";
      break;
    }
    out.insert(out.end(), chunk, chunk + produced);
    if (status == Z_BUF_ERROR || (status == Z_OK && produced == 0 && stream.avail_in == 0 && remaining_in == 0)) {
      error = "truncated: the compressed stream ends early (" + std::to_string(size) + " bytes of file)";
      break;
    }
  }
  if (status == Z_STREAM_END) {
    *ended = true;
    if (error.empty() && (stream.avail_in > 0 || remaining_in > 0))
      error = std::to_string(stream.avail_in + remaining_in) + " bytes follow the end of the gzip stream";
  }
  inflateEnd(&stream);
  DYPHO_CHECK_INPUT(error.empty()) << what << ": " << error;
  return out;
}

std::vector<uint8_t> Gzip(const std::vector<uint8_t>& raw, int level, const std::string& what) {
  z_stream stream{};
  DYPHO_CHECK_INPUT(deflateInit2(&stream, level, Z_DEFLATED, 16 + MAX_WBITS, 9, Z_DEFAULT_STRATEGY) == Z_OK)
      << what << ": zlib deflateInit2 failed";
  std::vector<uint8_t> out(deflateBound(&stream, raw.size()) + 64);
  stream.next_in = const_cast<Bytef*>(raw.data());
  stream.avail_in = static_cast<uInt>(raw.size());
  DYPHO_CHECK_INPUT(raw.size() < (1ull << 32)) << what << ": map too large for one deflate call";
  stream.next_out = out.data();
  stream.avail_out = static_cast<uInt>(out.size());
  const int status = deflate(&stream, Z_FINISH);
  out.resize(out.size() - stream.avail_out);
  deflateEnd(&stream);
  DYPHO_CHECK_INPUT(status == Z_STREAM_END) << what << ": zlib deflate failed (" << status << ")";
  return out;
}

}  // namespace

bool SpzOptions::IsValid(std::string* error) const {
  if (version != 2 && version != 3) {
    *error = "SpzOptions.version must be 2 or 3 (got " + std::to_string(version) + ")";
    return false;
  }
  if (compression_level < 1 || compression_level > 9) {
    *error = "SpzOptions.compression_level must be in 1..9 (got " + std::to_string(compression_level) + ")";
    return false;
  }
  return true;
}

std::vector<uint8_t> EncodeSpz(const GaussianCloud& cloud, const SpzOptions& options, const std::string& what) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << what << ": " << error;
  export_internal::CheckCloudForExport(cloud, what);
  const int degree = ShDegree(cloud.sh_coeffs);
  DYPHO_CHECK_INPUT(degree >= 0) << what << ": sh_coeffs " << cloud.sh_coeffs << " is not 1, 4, 9 or 16";
  const size_t n = cloud.size();
  const int k = cloud.sh_coeffs;
  Header header;
  header.version = static_cast<uint32_t>(options.version);
  header.num_points = static_cast<uint32_t>(n);
  header.sh_degree = static_cast<uint8_t>(degree);
  header.fractional_bits = static_cast<uint8_t>(FractionalBits(cloud, what));

  std::vector<uint8_t> raw(kHeaderBytes + BodyBytes(header.version, n, degree));
  uint8_t* h = raw.data();
  PutU32(h, header.magic);
  PutU32(h + 4, header.version);
  PutU32(h + 8, header.num_points);
  h[12] = header.sh_degree;
  h[13] = header.fractional_bits;
  h[14] = header.flags;
  h[15] = header.reserved;
  uint8_t* positions = raw.data() + kHeaderBytes;
  uint8_t* alphas = positions + 9 * n;
  uint8_t* colors = alphas + n;
  uint8_t* scales = colors + 3 * n;
  uint8_t* rotations = scales + 3 * n;
  uint8_t* sh = rotations + RotationBytes(header.version) * n;

  const double position_scale = std::ldexp(1.0, header.fractional_bits);
  for (size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      const int32_t fixed = static_cast<int32_t>(std::lround(kFlip[a] * cloud.means[3 * i + a] * position_scale));
      const uint32_t bits = static_cast<uint32_t>(fixed);
      for (int b = 0; b < 3; ++b) positions[9 * i + 3 * a + b] = static_cast<uint8_t>(bits >> (8 * b));
      scales[3 * i + a] = ToByte(16.0 * (cloud.log_scales[3 * i + a] + 10.0));
    }
    alphas[i] = ToByte(255.0 * export_internal::Sigmoid(cloud.opacity_logits[i]));
    const float* coeffs = &cloud.sh[i * k * 3];
    for (int c = 0; c < 3; ++c) colors[3 * i + c] = ToByte(255.0 * (kColorScale * coeffs[c] + 0.5));

    double wxyz[4];
    export_internal::NormalizedQuat(cloud, static_cast<int>(i), what, wxyz);
    // To the RUB frame (w, x, -y, -z), stored in x y z w order.
    const double q[4] = {wxyz[1], -wxyz[2], -wxyz[3], wxyz[0]};
    if (header.version >= 3) {
      PutU32(rotations + 4 * i, PackSmallestThree(q));
    } else {
      const double sign = q[3] < 0 ? -1.0 : 1.0;
      for (int j = 0; j < 3; ++j) rotations[3 * i + j] = ToByte(127.5 * sign * q[j] + 127.5);
    }

    uint8_t* out = sh + i * (k - 1) * 3;
    for (int j = 1; j < k; ++j) {
      const double step = j < 4 ? 8.0 : 16.0;
      for (int c = 0; c < 3; ++c) {
        const double v = export_internal::kShSignRotX180[j] * coeffs[3 * j + c];
        out[3 * (j - 1) + c] = ToByte(step * std::round((128.0 * v + 128.0) / step));
      }
    }
  }
  return Gzip(raw, options.compression_level, what);
}

GaussianCloud DecodeSpz(const uint8_t* data, size_t size, const std::string& what) {
  DYPHO_CHECK_INPUT(size >= 2) << what << ": " << size << " bytes is too short for a .spz file";
  if (size >= 4 && std::memcmp(data, "NGSP", 4) == 0) {
    DYPHO_CHECK_INPUT(false) << what << ": an uncompressed NGSP container (newer .spz versions); dypho reads the "
                             << "gzip-compressed versions 2 and 3";
  }
  DYPHO_CHECK_INPUT(data[0] == 0x1f && data[1] == 0x8b)
      << what << ": not a .spz file (no gzip signature 1f 8b at the start)";

  // The header first, to know how much data to expect.
  bool ended = false;
  const std::vector<uint8_t> head = Gunzip(data, size, kHeaderBytes, /*stop_at_limit=*/true, what, &ended);
  DYPHO_CHECK_INPUT(head.size() == kHeaderBytes)
      << what << ": truncated: " << head.size() << " bytes decompressed, the header alone has " << kHeaderBytes;
  Header header;
  header.magic = GetU32(head.data());
  header.version = GetU32(head.data() + 4);
  header.num_points = GetU32(head.data() + 8);
  header.sh_degree = head[12];
  header.fractional_bits = head[13];
  header.flags = head[14];
  header.reserved = head[15];
  DYPHO_CHECK_INPUT(header.magic == kMagic) << what << ": bad magic 0x" << std::hex << header.magic
                                            << " (a .spz file starts with 0x5053474e, \"NGSP\")";
  DYPHO_CHECK_INPUT(header.version != 1)
      << what << ": .spz version 1 (float16 positions) is not supported; dypho reads versions 2 and 3";
  DYPHO_CHECK_INPUT(header.version == 2 || header.version == 3)
      << what << ": unknown .spz version " << header.version << " (dypho reads versions 2 and 3)";
  DYPHO_CHECK_INPUT(header.sh_degree <= 3)
      << what << ": SH degree " << int(header.sh_degree) << " is not supported (0..3)";
  DYPHO_CHECK_INPUT(header.fractional_bits <= 23)
      << what << ": fractional_bits " << int(header.fractional_bits) << " leaves no integer bits (at most 23)";
  DYPHO_CHECK_INPUT((header.flags & kFlagExtensions) == 0)
      << what << ": the file has extensions (flag 0x2), which dypho does not read";
  DYPHO_CHECK_INPUT((header.flags & ~(kFlagAntialiased | kFlagExtensions)) == 0)
      << what << ": unknown flag bits 0x" << std::hex << int(header.flags) << " (only 0x1 is defined)";
  DYPHO_CHECK_INPUT(header.reserved == 0) << what << ": reserved header byte is " << int(header.reserved)
                                          << " (must be 0)";
  DYPHO_CHECK_INPUT(header.num_points <= static_cast<uint32_t>(INT32_MAX))
      << what << ": " << header.num_points << " points is more than dypho can hold";

  const size_t n = header.num_points;
  const int degree = header.sh_degree;
  const size_t expected = kHeaderBytes + BodyBytes(header.version, n, degree);
  const std::vector<uint8_t> raw = Gunzip(data, size, expected, /*stop_at_limit=*/false, what, &ended);
  DYPHO_CHECK_INPUT(raw.size() == expected)
      << what << ": truncated: the header says " << n << " points (" << expected << " bytes decompressed), the file holds "
      << raw.size();

  const int k = (degree + 1) * (degree + 1);
  GaussianCloud cloud;
  cloud.sh_coeffs = k;
  cloud.means.resize(3 * n);
  cloud.log_scales.resize(3 * n);
  cloud.quats.resize(4 * n);
  cloud.opacity_logits.resize(n);
  cloud.sh.assign(n * k * 3, 0.0f);
  const uint8_t* positions = raw.data() + kHeaderBytes;
  const uint8_t* alphas = positions + 9 * n;
  const uint8_t* colors = alphas + n;
  const uint8_t* scales = colors + 3 * n;
  const uint8_t* rotations = scales + 3 * n;
  const uint8_t* sh = rotations + RotationBytes(header.version) * n;
  const double inv_position_scale = std::ldexp(1.0, -header.fractional_bits);
  for (size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      const uint8_t* p = positions + 9 * i + 3 * a;
      uint32_t bits = uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16;
      if (bits & 0x800000u) bits |= 0xff000000u;  // sign extension
      cloud.means[3 * i + a] = static_cast<float>(kFlip[a] * static_cast<int32_t>(bits) * inv_position_scale);
      cloud.log_scales[3 * i + a] = static_cast<float>(scales[3 * i + a] / 16.0 - 10.0);
    }
    const double alpha = std::clamp(alphas[i] / 255.0, 0.5 / 255.0, 254.5 / 255.0);
    cloud.opacity_logits[i] = static_cast<float>(std::log(alpha / (1.0 - alpha)));
    float* coeffs = &cloud.sh[i * k * 3];
    for (int c = 0; c < 3; ++c) coeffs[c] = static_cast<float>((colors[3 * i + c] / 255.0 - 0.5) / kColorScale);

    double q[4];  // x y z w in the RUB frame
    if (header.version >= 3) {
      UnpackSmallestThree(GetU32(rotations + 4 * i), q);
    } else {
      double sum_squares = 0.0;
      for (int j = 0; j < 3; ++j) {
        q[j] = rotations[3 * i + j] / 127.5 - 1.0;
        sum_squares += q[j] * q[j];
      }
      q[3] = std::sqrt(std::max(0.0, 1.0 - sum_squares));
    }
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);  // > 0 by construction
    // Back to dypho's frame, w x y z.
    cloud.quats[4 * i + 0] = static_cast<float>(q[3] / norm);
    cloud.quats[4 * i + 1] = static_cast<float>(q[0] / norm);
    cloud.quats[4 * i + 2] = static_cast<float>(-q[1] / norm);
    cloud.quats[4 * i + 3] = static_cast<float>(-q[2] / norm);

    const uint8_t* in = sh + i * (k - 1) * 3;
    for (int j = 1; j < k; ++j) {
      for (int c = 0; c < 3; ++c)
        coeffs[3 * j + c] =
            static_cast<float>(export_internal::kShSignRotX180[j] * (in[3 * (j - 1) + c] - 128.0) / 128.0);
    }
  }
  return cloud;
}

void SaveSpz(const GaussianCloud& cloud, const std::string& path, const SpzOptions& options) {
  const std::vector<uint8_t> bytes = EncodeSpz(cloud, options, path);
  WriteFileAtomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    DYPHO_CHECK_INPUT(out.good()) << "cannot open " << tmp << " for writing";
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.close();
    DYPHO_CHECK_INPUT(out.good()) << "error writing " << tmp;
  });
}

GaussianCloud LoadSpz(const std::string& path) {
  DYPHO_CHECK_INPUT(std::filesystem::is_regular_file(path)) << "cannot open " << path << ": no such file";
  const std::string data = export_internal::ReadWholeFile(path);
  return DecodeSpz(reinterpret_cast<const uint8_t*>(data.data()), data.size(), path);
}

}  // namespace dypho
