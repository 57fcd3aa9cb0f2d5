// The .spz export and import (engine/export/spz.h): round trips within the
// quantisation error the header documents, for both versions and every SH
// degree; the bytes checked by a reader written here from the format
// specification (its own zlib inflate, header fields, array sizes, known
// answers for single Gaussians); corrupt, truncated and unsupported files.
#include <zlib.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/check.h"
#include "engine/export/export.h"
#include "engine/export/spz.h"
#include "engine/gaussians.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using ::dypho::testing::TestTempDir;

double Sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

// Values inside the ranges where the documented bounds hold.
GaussianCloud RandomCloud(int n, int sh_coeffs, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, 1.0f);
  GaussianCloud cloud;
  cloud.sh_coeffs = sh_coeffs;
  std::vector<float> coeffs(3 * sh_coeffs);
  for (int i = 0; i < n; ++i) {
    const float mean[3] = {5 * u(rng), 5 * u(rng), 5 * u(rng) + 3};
    const float log_scale[3] = {-4 + 5 * u(rng), -4 + 5 * u(rng), -4 + 5 * u(rng)};
    const float quat[4] = {g(rng), g(rng), g(rng), g(rng)};  // uniform rotations, not normalised
    for (int c = 0; c < 3; ++c) coeffs[c] = 3.3f * u(rng);
    for (int j = 3; j < 3 * sh_coeffs; ++j) coeffs[j] = u(rng);
    cloud.Add(mean, log_scale, quat, 6 * u(rng), coeffs.data());
  }
  return cloud;
}

// Angle [deg] between the rotations of two quaternions (w x y z, any norm).
double RotationAngleDeg(const float* a, const float* b) {
  double dot = 0, na = 0, nb = 0;
  for (int j = 0; j < 4; ++j) {
    dot += double(a[j]) * b[j];
    na += double(a[j]) * a[j];
    nb += double(b[j]) * b[j];
  }
  const double c = std::min(1.0, std::fabs(dot) / std::sqrt(na * nb));
  return 2 * std::acos(c) * 180 / M_PI;
}

struct Errors {
  double position = 0, opacity = 0, dc = 0, log_scale = 0, rotation_deg = 0, sh1 = 0, sh23 = 0;
};

Errors RoundTripErrors(const GaussianCloud& a, const GaussianCloud& b) {
  Errors e;
  const int k = a.sh_coeffs;
  for (int i = 0; i < a.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      e.position = std::max(e.position, double(std::fabs(a.means[3 * i + c] - b.means[3 * i + c])));
      e.log_scale = std::max(e.log_scale, double(std::fabs(a.log_scales[3 * i + c] - b.log_scales[3 * i + c])));
    }
    e.opacity = std::max(e.opacity, std::fabs(Sigmoid(a.opacity_logits[i]) - Sigmoid(b.opacity_logits[i])));
    e.rotation_deg = std::max(e.rotation_deg, RotationAngleDeg(&a.quats[4 * i], &b.quats[4 * i]));
    for (int j = 0; j < k; ++j) {
      for (int c = 0; c < 3; ++c) {
        const size_t at = (static_cast<size_t>(i) * k + j) * 3 + c;
        const double d = std::fabs(a.sh[at] - b.sh[at]);
        double& slot = j == 0 ? e.dc : j < 4 ? e.sh1 : e.sh23;
        slot = std::max(slot, d);
      }
    }
  }
  return e;
}

// --- An independent reader: zlib inflate of the whole gzip stream, then the
// fields as the specification lays them out.
std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteFile(const std::string& path, const std::string& data) {
  std::ofstream out(path, std::ios::binary);
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
}

std::string Inflate(const std::string& gz) {
  z_stream s{};
  EXPECT_EQ(inflateInit2(&s, 31), Z_OK);
  s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(gz.data()));
  s.avail_in = static_cast<uInt>(gz.size());
  std::string out;
  char buf[4096];
  int rc = Z_OK;
  while (rc == Z_OK) {
    s.next_out = reinterpret_cast<Bytef*>(buf);
    s.avail_out = sizeof(buf);
    rc = inflate(&s, Z_NO_FLUSH);
    out.append(buf, sizeof(buf) - s.avail_out);
  }
  EXPECT_EQ(rc, Z_STREAM_END);
  inflateEnd(&s);
  return out;
}

std::string Deflate(const std::string& raw) {
  z_stream s{};
  EXPECT_EQ(deflateInit2(&s, 6, Z_DEFLATED, 31, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&s, raw.size()) + 32, '\0');
  s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
  s.avail_in = static_cast<uInt>(raw.size());
  s.next_out = reinterpret_cast<Bytef*>(out.data());
  s.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&s, Z_FINISH), Z_STREAM_END);
  out.resize(out.size() - s.avail_out);
  deflateEnd(&s);
  return out;
}

uint32_t U32(const std::string& s, size_t at) {
  uint32_t v = 0;
  for (int b = 3; b >= 0; --b) v = v << 8 | static_cast<uint8_t>(s[at + b]);
  return v;
}

int32_t I24(const std::string& s, size_t at) {
  int32_t v = static_cast<uint8_t>(s[at]) | static_cast<uint8_t>(s[at + 1]) << 8 | static_cast<uint8_t>(s[at + 2]) << 16;
  return v >= (1 << 23) ? v - (1 << 24) : v;
}

uint8_t Byte(const std::string& s, size_t at) { return static_cast<uint8_t>(s[at]); }

std::string Header(uint32_t version, uint32_t n, int degree, int fractional_bits, int flags = 0, int reserved = 0) {
  std::string h(16, '\0');
  const uint32_t words[3] = {0x5053474eu, version, n};
  for (int w = 0; w < 3; ++w)
    for (int b = 0; b < 4; ++b) h[4 * w + b] = static_cast<char>(words[w] >> (8 * b));
  h[12] = static_cast<char>(degree);
  h[13] = static_cast<char>(fractional_bits);
  h[14] = static_cast<char>(flags);
  h[15] = static_cast<char>(reserved);
  return h;
}

GaussianCloud OneGaussian(float x, float y, float z, const float quat[4]) {
  GaussianCloud c;
  const float mean[3] = {x, y, z};
  const float log_scale[3] = {-2.0f, 0.0f, 1.5f};
  const float coeffs[3] = {1.0f, -0.5f, 0.0f};
  c.Add(mean, log_scale, quat, 0.0f, coeffs);
  return c;
}

TEST(SpzExport, RoundTripIsWithinTheDocumentedErrorForBothVersionsAndEverySHDegree) {
  const std::string dir = TestTempDir();
  for (int version : {3, 2}) {
    for (int k : {1, 4, 9, 16}) {
      SCOPED_TRACE("version " + std::to_string(version) + ", sh_coeffs " + std::to_string(k));
      const GaussianCloud cloud = RandomCloud(4000, k, 7 + k);
      const std::string path = dir + "/map_v" + std::to_string(version) + "_" + std::to_string(k) + ".spz";
      SpzOptions options;
      options.version = version;
      SaveSpz(cloud, path, options);
      const GaussianCloud back = LoadSpz(path);
      ASSERT_EQ(back.size(), cloud.size());
      ASSERT_EQ(back.sh_coeffs, k);
      const Errors e = RoundTripErrors(cloud, back);
      std::printf("v%d K=%2d: position %.2e m, opacity %.2e, f_dc %.4f, log_scale %.4f, rotation %.3f deg, "
                  "SH1 %.4f, SH2-3 %.4f\n", version, k, e.position, e.opacity, e.dc, e.log_scale, e.rotation_deg,
                  e.sh1, e.sh23);
      EXPECT_LE(e.position, std::ldexp(1.0, -13) + 1e-6);  // 12 fractional bits (+ float rounding of 8 m)
      EXPECT_LE(e.opacity, 0.5 / 255 + 1e-6);
      EXPECT_LE(e.dc, 0.5 / (255 * 0.15) + 1e-5);
      EXPECT_LE(e.log_scale, 1.0 / 32 + 1e-5);
      EXPECT_LE(e.sh1, 1.0 / 32 + 1e-6);
      EXPECT_LE(e.sh23, 1.0 / 16 + 1e-6);
      for (int i = 0; i < back.size(); ++i) {
        const float* q = &back.quats[4 * i];
        EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0f, 1e-5f) << "Gaussian " << i;
        ASSERT_TRUE(std::isfinite(back.opacity_logits[i]));
      }
      if (version == 3) {
        EXPECT_LE(e.rotation_deg, 0.3);
      } else {
        // Version 2 stores x y z with w >= 0: each within 1/255, so the error
        // is bounded where |w| is not small (spz.h derives 1.6 degrees).
        double worst = 0.0;
        for (int i = 0; i < back.size(); ++i) {
          const float* q = &cloud.quats[4 * i];
          const double w = std::fabs(q[0]) / std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
          if (w >= 0.5) worst = std::max(worst, RotationAngleDeg(q, &back.quats[4 * i]));
        }
        std::printf("v2 rotation error where |w| >= 0.5: %.3f deg\n", worst);
        EXPECT_LE(worst, 1.6);
      }
    }
  }
}

TEST(SpzExport, AnIndependentReaderFindsTheHeaderSizesAndValues) {
  const std::string dir = TestTempDir();
  for (int version : {3, 2}) {
    for (int k : {1, 4, 9, 16}) {
      SCOPED_TRACE("version " + std::to_string(version) + ", sh_coeffs " + std::to_string(k));
      const int n = 37;
      const GaussianCloud cloud = RandomCloud(n, k, 3);
      const std::string path = dir + "/map.spz";
      SpzOptions options;
      options.version = version;
      SaveSpz(cloud, path, options);
      const std::string gz = ReadFile(path);
      ASSERT_GE(gz.size(), 18u);
      EXPECT_EQ(Byte(gz, 0), 0x1f);  // gzip (RFC 1952)
      EXPECT_EQ(Byte(gz, 1), 0x8b);
      const std::string raw = Inflate(gz);
      ASSERT_GE(raw.size(), 16u);
      EXPECT_EQ(raw.substr(0, 4), "NGSP");
      EXPECT_EQ(U32(raw, 4), static_cast<uint32_t>(version));
      EXPECT_EQ(U32(raw, 8), static_cast<uint32_t>(n));
      EXPECT_EQ(Byte(raw, 12), static_cast<int>(std::lround(std::sqrt(k))) - 1);  // SH degree
      EXPECT_EQ(Byte(raw, 13), 12);                                               // fractional bits
      EXPECT_EQ(Byte(raw, 14), 0);                                                // flags
      EXPECT_EQ(Byte(raw, 15), 0);                                                // reserved
      const size_t rotation = version == 3 ? 4 : 3;
      EXPECT_EQ(raw.size(), 16 + n * (9 + 1 + 3 + 3 + rotation + 3 * (k - 1)));
      // Positions, alphas, colours and scales of every Gaussian, by hand.
      const size_t pos = 16, alpha = pos + 9 * n, color = alpha + n, scale = color + 3 * n;
      for (int i = 0; i < n; ++i) {
        const double sign[3] = {1, -1, -1};  // RDF -> RUB
        for (int a = 0; a < 3; ++a) {
          EXPECT_EQ(I24(raw, pos + 9 * i + 3 * a), std::lround(sign[a] * cloud.means[3 * i + a] * 4096.0));
          EXPECT_EQ(Byte(raw, scale + 3 * i + a), std::lround((cloud.log_scales[3 * i + a] + 10) * 16));
          EXPECT_EQ(Byte(raw, color + 3 * i + a),
                    std::clamp(std::lround(255 * (0.15 * cloud.sh[i * k * 3 + a] + 0.5)), 0L, 255L));
        }
        EXPECT_EQ(Byte(raw, alpha + i), std::lround(255 * Sigmoid(cloud.opacity_logits[i])));
      }
    }
  }
}

TEST(SpzExport, KnownRotationBytes) {
  const std::string dir = TestTempDir();
  const float identity[4] = {1, 0, 0, 0};
  // 1 rad about x: (cos 0.5, sin 0.5, 0, 0); in RUB (w, x, -y, -z), stored x y z w.
  const float about_x[4] = {static_cast<float>(std::cos(0.5)), static_cast<float>(std::sin(0.5)), 0, 0};
  const size_t rot3 = 16 + 16;  // one Gaussian: 9 + 1 + 3 + 3 bytes before the rotation
  SaveSpz(OneGaussian(0.25f, -1.5f, 2.0f, identity), dir + "/id.spz");
  std::string raw = Inflate(ReadFile(dir + "/id.spz"));
  ASSERT_EQ(raw.size(), rot3 + 4);
  EXPECT_EQ(U32(raw, rot3), 3u << 30);  // largest is w (index 3), the others 0
  EXPECT_EQ(I24(raw, 16), 1024);        // 0.25 m * 4096
  EXPECT_EQ(I24(raw, 19), 6144);        // y flipped: 1.5 m * 4096
  EXPECT_EQ(I24(raw, 22), -8192);       // z flipped
  EXPECT_EQ(Byte(raw, 25), 128);        // alpha: 255 sigmoid(0) = 127.5 -> 128
  EXPECT_EQ(Byte(raw, 26), 166);        // colour: 255 (0.15 + 0.5) = 165.75
  EXPECT_EQ(Byte(raw, 27), 108);        // 255 (-0.075 + 0.5) = 108.4
  EXPECT_EQ(Byte(raw, 29), 128);        // scale: 16 (-2 + 10)
  EXPECT_EQ(Byte(raw, 30), 160);        // 16 * 10
  EXPECT_EQ(Byte(raw, 31), 184);        // 16 * 11.5
  SaveSpz(OneGaussian(0, 0, 0, about_x), dir + "/x.spz");
  raw = Inflate(ReadFile(dir + "/x.spz"));
  // w largest (index 3); x = sin 0.5 -> round(511 * 0.4794 * sqrt 2) = 346 in bits 20..28; y = z = 0.
  EXPECT_EQ(U32(raw, rot3), (3u << 30) | (346u << 20));
  SpzOptions v2;
  v2.version = 2;
  SaveSpz(OneGaussian(0, 0, 0, about_x), dir + "/x2.spz", v2);
  raw = Inflate(ReadFile(dir + "/x2.spz"));
  ASSERT_EQ(raw.size(), rot3 + 3);
  EXPECT_EQ(Byte(raw, rot3), 189);      // 127.5 * 0.4794 + 127.5 = 188.6
  EXPECT_EQ(Byte(raw, rot3 + 1), 128);  // 127.5 -> 128 (round half away from zero)
  EXPECT_EQ(Byte(raw, rot3 + 2), 128);
  // w < 0 is negated away in version 2: -q is the same rotation and gives the same bytes.
  const float negated[4] = {-about_x[0], -about_x[1], 0, 0};
  SaveSpz(OneGaussian(0, 0, 0, negated), dir + "/x2n.spz", v2);
  EXPECT_EQ(Inflate(ReadFile(dir + "/x2n.spz")), raw);
}

TEST(SpzExport, LargeMapsUseFewerFractionalBitsAndHugeOnesAreAnError) {
  const std::string dir = TestTempDir();
  const float identity[4] = {1, 0, 0, 0};
  GaussianCloud cloud = OneGaussian(3000.0f, -20.0f, 0.5f, identity);  // 3000 m needs 12 integer bits
  SaveSpz(cloud, dir + "/wide.spz");
  const std::string raw = Inflate(ReadFile(dir + "/wide.spz"));
  EXPECT_EQ(Byte(raw, 13), 11);
  const GaussianCloud back = LoadSpz(dir + "/wide.spz");
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(back.means[a], cloud.means[a], std::ldexp(1.0, -12));
  cloud.means[0] = 1e7f;
  try {
    SaveSpz(cloud, dir + "/huge.spz");
    ADD_FAILURE() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("24-bit"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir + "/huge.spz"));
}

TEST(SpzExport, EmptyMapsOptionsAndBadClouds) {
  const std::string dir = TestTempDir();
  GaussianCloud empty;
  SaveSpz(empty, dir + "/empty.spz");
  EXPECT_EQ(Inflate(ReadFile(dir + "/empty.spz")).size(), 16u);
  const GaussianCloud back = LoadSpz(dir + "/empty.spz");
  EXPECT_TRUE(back.empty());
  EXPECT_EQ(back.sh_coeffs, 1);

  SpzOptions bad;
  bad.version = 4;
  std::string error;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(error.find("SpzOptions.version"), std::string::npos);
  EXPECT_THROW(SaveSpz(RandomCloud(3, 1, 1), dir + "/v4.spz", bad), InvalidInput);
  bad = SpzOptions();
  bad.compression_level = 0;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(error.find("compression_level"), std::string::npos);

  GaussianCloud nan = RandomCloud(3, 4, 1);
  nan.log_scales[4] = NAN;
  EXPECT_THROW(SaveSpz(nan, dir + "/nan.spz"), InvalidInput);
  GaussianCloud zero = RandomCloud(3, 4, 1);
  std::fill(zero.quats.begin() + 4, zero.quats.begin() + 8, 0.0f);
  EXPECT_THROW(SaveSpz(zero, dir + "/zero.spz"), InvalidInput);
  EXPECT_FALSE(fs::exists(dir + "/nan.spz"));
  EXPECT_FALSE(fs::exists(dir + "/zero.spz"));
  EXPECT_FALSE(fs::exists(dir + "/v4.spz"));
}

TEST(SpzExport, SaveMapAndLoadMapChooseSpzByExtension) {
  const std::string dir = TestTempDir();
  const GaussianCloud cloud = RandomCloud(50, 9, 11);
  EXPECT_EQ(MapFormatFromPath("a/b.SPZ"), MapFormat::kSpz);
  SaveMap(cloud, dir + "/m.spz");
  const GaussianCloud a = LoadMap(dir + "/m.spz");
  const GaussianCloud b = LoadSpz(dir + "/m.spz");
  EXPECT_EQ(a.means, b.means);
  EXPECT_EQ(a.sh, b.sh);
  EXPECT_EQ(a.sh_coeffs, 9);
  // Encoding is deterministic: the same map gives the same bytes.
  EXPECT_EQ(EncodeSpz(cloud, SpzOptions(), "x"), EncodeSpz(cloud, SpzOptions(), "y"));
}

void ExpectLoadError(const std::string& path, const std::string& needle) {
  try {
    LoadSpz(path);
    ADD_FAILURE() << path << ": no error (expected '" << needle << "')";
  } catch (const InvalidInput& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(needle), std::string::npos) << "expected '" << needle << "' in: " << message;
  }
}

TEST(SpzImport, CorruptTruncatedAndUnsupportedFilesAreClearErrors) {
  const std::string dir = TestTempDir();
  const GaussianCloud cloud = RandomCloud(500, 4, 5);
  SaveSpz(cloud, dir + "/good.spz");
  const std::string good = ReadFile(dir + "/good.spz");
  const std::string raw = Inflate(good);
  auto write = [&](const std::string& name, const std::string& data) {
    WriteFile(dir + "/" + name, data);
    return dir + "/" + name;
  };

  ExpectLoadError(dir + "/missing.spz", "no such file");
  ExpectLoadError(write("empty.spz", ""), "too short");
  ExpectLoadError(write("text.spz", "ply\nformat ascii 1.0\n"), "no gzip signature");
  ExpectLoadError(write("ngsp.spz", "NGSP" + std::string(28, '\0')), "uncompressed NGSP container");
  // Truncated anywhere: in the gzip header, in the deflate data, in the trailer.
  for (size_t keep : {size_t(5), size_t(12), good.size() / 2, good.size() - 5, good.size() - 1})
    ExpectLoadError(write("cut" + std::to_string(keep) + ".spz", good.substr(0, keep)), "truncated");
  // A flipped byte in the compressed data: zlib finds it (a bad code or the CRC).
  std::string flipped = good;
  flipped[good.size() / 2] = static_cast<char>(flipped[good.size() / 2] ^ 0x55);
  ExpectLoadError(write("flipped.spz", flipped), "corrupt compressed data");
  ExpectLoadError(write("junk.spz", good + "junk"), "bytes follow the end of the gzip stream");

  // Well-compressed streams with bad contents.
  const std::string body = raw.substr(16);
  ExpectLoadError(write("magic.spz", Deflate("XGSP" + raw.substr(4))), "bad magic");
  ExpectLoadError(write("v1.spz", Deflate(Header(1, 500, 1, 12) + body)), "version 1");
  ExpectLoadError(write("v4.spz", Deflate(Header(4, 500, 1, 12) + body)), "unknown .spz version 4");
  ExpectLoadError(write("sh4.spz", Deflate(Header(3, 500, 4, 12) + body)), "SH degree 4");
  ExpectLoadError(write("ext.spz", Deflate(Header(3, 500, 1, 12, 0x2) + body)), "extensions");
  ExpectLoadError(write("flags.spz", Deflate(Header(3, 500, 1, 12, 0x80) + body)), "unknown flag bits");
  ExpectLoadError(write("reserved.spz", Deflate(Header(3, 500, 1, 12, 0, 7) + body)), "reserved header byte");
  ExpectLoadError(write("bits.spz", Deflate(Header(3, 500, 1, 24) + body)), "fractional_bits");
  ExpectLoadError(write("short.spz", Deflate(raw.substr(0, 10))), "header alone");
  // The header's count against the data: more points than data (a body cut
  // short, or a count of 4 billion), or data left over.
  ExpectLoadError(write("fewer.spz", Deflate(raw.substr(0, raw.size() - 7))), "truncated: the header says 500");
  ExpectLoadError(write("count.spz", Deflate(Header(3, 0x7fffffff, 1, 12) + body)), "truncated: the header says");
  ExpectLoadError(write("more.spz", Deflate(raw + std::string(9, '\0'))), "more than");
  ExpectLoadError(write("wrongsh.spz", Deflate(Header(3, 500, 2, 12) + body)), "truncated");
  // The version-2 layout read as version 3 (rotations one byte shorter each).
  ExpectLoadError(write("v2as3.spz", Deflate(Header(2, 500, 1, 12) + body)), "more than");

  // The good file still loads (nothing above was cached or half-read).
  EXPECT_EQ(LoadSpz(dir + "/good.spz").size(), 500);
  // A flag the format defines (antialiased) is accepted.
  EXPECT_EQ(LoadSpz(write("aa.spz", Deflate(Header(3, 500, 1, 12, 0x1) + body))).size(), 500);
}

}  // namespace
}  // namespace dypho
