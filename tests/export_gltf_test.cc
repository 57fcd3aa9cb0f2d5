// .splat (quantisation bounds, sort order) and glTF with
// KHR_gaussian_splatting (JSON, GLB chunks, decoded buffers after the frame
// conversion), each checked by a reader written here from the format
// description.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/check.h"
#include "engine/export/export.h"
#include "engine/export/gltf.h"
#include "engine/export/ply.h"
#include "engine/export/splat.h"
#include "engine/gaussians.h"
#include "kernels/math/sh.h"
#include "tests/export_test_util.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using ::dypho::testing::TestTempDir;
using export_testing::RandomCloud;
using export_testing::ReadAll;
using export_testing::WriteAll;

// ---------------------------------------------------------------------------
// .splat

constexpr double kC0 = 0.28209479177387814;

double SigmoidD(double x) { return 1.0 / (1.0 + std::exp(-x)); }

std::vector<double> UnitQuat(const GaussianCloud& cloud, int i) {
  double norm = 0;
  for (int j = 0; j < 4; ++j) norm += double(cloud.quats[4 * i + j]) * cloud.quats[4 * i + j];
  norm = std::sqrt(norm);
  std::vector<double> q(4);
  for (int j = 0; j < 4; ++j) q[j] = cloud.quats[4 * i + j] / norm;
  return q;
}

struct SplatRecord {
  float position[3], scale[3];
  uint8_t rgba[4], rot[4];
};

std::vector<SplatRecord> DecodeSplatFile(const std::string& bytes) {
  std::vector<SplatRecord> records(bytes.size() / 32);
  for (size_t r = 0; r < records.size(); ++r) {
    const char* p = bytes.data() + 32 * r;
    std::memcpy(records[r].position, p, 12);
    std::memcpy(records[r].scale, p + 12, 12);
    std::memcpy(records[r].rgba, p + 24, 4);
    std::memcpy(records[r].rot, p + 28, 4);
  }
  return records;
}

TEST(SplatExport, KnownAnswerForOneSplat) {
  const std::string dir = TestTempDir();
  GaussianCloud cloud;
  const float mean[3] = {1.0f, -2.0f, 3.5f};
  const float log_scale[3] = {std::log(0.5f), 0.0f, std::log(2.0f)};
  const float quat[4] = {2.0f, 0.0f, 0.0f, 0.0f};  // unnormalised identity
  const float dc[3] = {0.0f, 100.0f, -100.0f};      // grey 0.5, clamped to 1 and 0
  cloud.Add(mean, log_scale, quat, 0.0f, dc);
  SaveSplat(cloud, dir + "/one.splat");
  const std::string bytes = ReadAll(dir + "/one.splat");
  ASSERT_EQ(bytes.size(), 32u);
  const SplatRecord r = DecodeSplatFile(bytes)[0];
  EXPECT_EQ(r.position[0], 1.0f);
  EXPECT_EQ(r.position[1], -2.0f);
  EXPECT_EQ(r.position[2], 3.5f);
  EXPECT_FLOAT_EQ(r.scale[0], 0.5f);
  EXPECT_FLOAT_EQ(r.scale[1], 1.0f);
  EXPECT_FLOAT_EQ(r.scale[2], 2.0f);
  // 0.5 * 255 = 127.5 rounds to 128; sigmoid(0) = 0.5 likewise.
  EXPECT_EQ(r.rgba[0], 128);
  EXPECT_EQ(r.rgba[1], 255);
  EXPECT_EQ(r.rgba[2], 0);
  EXPECT_EQ(r.rgba[3], 128);
  // w = 1 maps to 256, clamped to 255; x = y = z = 0 map to 128.
  EXPECT_EQ(r.rot[0], 255);
  EXPECT_EQ(r.rot[1], 128);
  EXPECT_EQ(r.rot[2], 128);
  EXPECT_EQ(r.rot[3], 128);
}

TEST(SplatExport, BytesDecodeToTheCloudWithinQuantisationAndAreSortedByImportance) {
  const std::string dir = TestTempDir();
  const int n = 500;
  const GaussianCloud cloud = RandomCloud(n, 4, 7);  // degree 1: only f_dc is stored
  SaveSplat(cloud, dir + "/map.splat");
  const std::string bytes = ReadAll(dir + "/map.splat");
  ASSERT_EQ(bytes.size(), 32u * n);
  const std::vector<SplatRecord> records = DecodeSplatFile(bytes);
  std::vector<int> seen(n, 0);
  double previous_importance = INFINITY;
  for (const SplatRecord& r : records) {
    // Positions are stored exactly and are distinct: they identify the Gaussian.
    int i = -1;
    for (int j = 0; j < n; ++j) {
      if (std::memcmp(&cloud.means[3 * j], r.position, 12) == 0) i = j;
    }
    ASSERT_GE(i, 0);
    ++seen[i];
    for (int a = 0; a < 3; ++a) EXPECT_EQ(r.scale[a], std::exp(cloud.log_scales[3 * i + a]));
    for (int c = 0; c < 3; ++c) {
      const double color = std::clamp(0.5 + kC0 * cloud.sh[(i * 4) * 3 + c], 0.0, 1.0);
      EXPECT_NEAR(r.rgba[c] / 255.0, color, 0.5 / 255 + 1e-6);
    }
    EXPECT_NEAR(r.rgba[3] / 255.0, SigmoidD(cloud.opacity_logits[i]), 0.5 / 255 + 1e-6);
    const std::vector<double> q = UnitQuat(cloud, i);
    for (int j = 0; j < 4; ++j) {
      if (q[j] * 128 + 128 >= 255.5) {
        EXPECT_EQ(r.rot[j], 255);  // +1 cannot be represented; clamped
      } else {
        EXPECT_NEAR((r.rot[j] - 128) / 128.0, q[j], 0.5 / 128 + 1e-9);
      }
    }
    // Descending exp(sum log scales) * sigmoid(opacity).
    const double importance =
        std::exp(double(cloud.log_scales[3 * i]) + cloud.log_scales[3 * i + 1] + cloud.log_scales[3 * i + 2]) *
        SigmoidD(cloud.opacity_logits[i]);
    EXPECT_LE(importance, previous_importance);
    previous_importance = importance;
  }
  for (int i = 0; i < n; ++i) EXPECT_EQ(seen[i], 1) << "Gaussian " << i;
}

TEST(SplatImport, RoundTripWithinQuantisation) {
  const std::string dir = TestTempDir();
  const int n = 200;
  const GaussianCloud cloud = RandomCloud(n, 1, 8);
  SaveSplat(cloud, dir + "/map.splat");
  const GaussianCloud back = LoadSplat(dir + "/map.splat");
  ASSERT_EQ(back.size(), n);
  EXPECT_EQ(back.sh_coeffs, 1);
  for (int r = 0; r < n; ++r) {
    int i = -1;
    for (int j = 0; j < n; ++j) {
      if (std::memcmp(&cloud.means[3 * j], &back.means[3 * r], 12) == 0) i = j;
    }
    ASSERT_GE(i, 0);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(back.log_scales[3 * r + a], cloud.log_scales[3 * i + a], 1e-5);
    for (int c = 0; c < 3; ++c) {
      const double color = std::clamp(0.5 + kC0 * cloud.sh[3 * i + c], 0.0, 1.0);
      EXPECT_NEAR(0.5 + kC0 * back.sh[3 * r + c], color, 0.5 / 255 + 1e-6);
    }
    EXPECT_NEAR(SigmoidD(back.opacity_logits[r]), SigmoidD(cloud.opacity_logits[i]), 0.5 / 255 + 1e-6);
    const std::vector<double> q = UnitQuat(cloud, i);
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(back.quats[4 * r + j], q[j], 1.0 / 128 + 1e-9);
  }
}

TEST(SplatExport, EmptyCloudAndBadInput) {
  const std::string dir = TestTempDir();
  SaveSplat(GaussianCloud(), dir + "/empty.splat");
  EXPECT_EQ(fs::file_size(dir + "/empty.splat"), 0u);
  EXPECT_TRUE(LoadSplat(dir + "/empty.splat").empty());

  GaussianCloud cloud = RandomCloud(4, 1, 9);
  std::fill(cloud.quats.begin() + 8, cloud.quats.begin() + 12, 0.0f);
  EXPECT_INVALID_INPUT(SaveSplat(cloud, dir + "/bad.splat"), "Gaussian 2 has a zero quaternion");
  cloud = RandomCloud(4, 1, 9);
  cloud.log_scales[4] = 200.0f;
  EXPECT_INVALID_INPUT(SaveSplat(cloud, dir + "/bad.splat"), "Gaussian 1 has log_scale 200");
  EXPECT_FALSE(fs::exists(dir + "/bad.splat"));

  EXPECT_INVALID_INPUT(LoadSplat(dir + "/missing.splat"), "missing.splat: no such file");
  SaveSplat(RandomCloud(3, 1, 10), dir + "/three.splat");
  const std::string bytes = ReadAll(dir + "/three.splat");
  WriteAll(dir + "/cut.splat", bytes.substr(0, 70));
  EXPECT_INVALID_INPUT(LoadSplat(dir + "/cut.splat"), "size 70 bytes is not a multiple of 32");
  std::string negative = bytes;
  const float minus = -1.0f;
  std::memcpy(&negative[32 * 2 + 16], &minus, 4);
  WriteAll(dir + "/negative.splat", negative);
  EXPECT_INVALID_INPUT(LoadSplat(dir + "/negative.splat"), "splat 2 has scale -1");
}

// ---------------------------------------------------------------------------
// glTF with KHR_gaussian_splatting

uint32_t U32At(const std::string& s, size_t offset) {
  uint32_t v;
  std::memcpy(&v, s.data() + offset, 4);
  return v;
}

// Splits a GLB into its JSON and BIN chunks (glTF 2.0 spec, "Binary glTF Layout").
void ParseGlb(const std::string& glb, nlohmann::json* json, std::string* bin) {
  ASSERT_GE(glb.size(), 20u);
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  EXPECT_EQ(U32At(glb, 4), 2u);
  EXPECT_EQ(U32At(glb, 8), glb.size());
  const uint32_t json_length = U32At(glb, 12);
  EXPECT_EQ(U32At(glb, 16), 0x4E4F534Au);  // "JSON"
  EXPECT_EQ(json_length % 4, 0u);
  *json = nlohmann::json::parse(glb.substr(20, json_length));
  const size_t bin_header = 20 + json_length;
  ASSERT_GE(glb.size(), bin_header + 8);
  const uint32_t bin_length = U32At(glb, bin_header);
  EXPECT_EQ(U32At(glb, bin_header + 4), 0x004E4942u);  // "BIN\0"
  EXPECT_EQ(bin_length % 4, 0u);
  ASSERT_EQ(glb.size(), bin_header + 8 + bin_length);
  *bin = glb.substr(bin_header + 8, bin_length);
}

std::string DecodeBase64(const std::string& text) {
  const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  uint32_t bits = 0;
  int count = 0;
  for (char ch : text) {
    if (ch == '=') break;
    const size_t v = alphabet.find(ch);
    if (v == std::string::npos) continue;
    bits = (bits << 6) | static_cast<uint32_t>(v);
    count += 6;
    if (count >= 8) {
      count -= 8;
      out.push_back(static_cast<char>((bits >> count) & 0xFF));
    }
  }
  return out;
}

// Hamilton product of (w, x, y, z) quaternions.
std::vector<double> QuatMul(const std::vector<double>& a, const std::vector<double>& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3], a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1], a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

// Covariance R S S^T R^T from a quaternion given as x y z w (the extension's
// rotation-matrix formula) and linear scales; row-major 3x3.
std::vector<double> Covariance(double qx, double qy, double qz, double qw, const double s[3]) {
  const double r[9] = {1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz),     2 * (qx * qz + qw * qy),
                       2 * (qx * qy + qw * qz),     1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx),
                       2 * (qx * qz - qw * qy),     2 * (qy * qz + qw * qx),     1 - 2 * (qx * qx + qy * qy)};
  std::vector<double> cov(9, 0.0);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int a = 0; a < 3; ++a) cov[3 * i + j] += r[3 * i + a] * s[a] * s[a] * r[3 * j + a];
    }
  }
  return cov;
}

// Reads accessor `index` as floats after checking its layout.
std::vector<float> AccessorFloats(const nlohmann::json& gltf, const std::string& bin, int index, const char* type,
                                  int components, size_t count) {
  const auto& accessor = gltf["accessors"][index];
  EXPECT_EQ(accessor["type"], type);
  EXPECT_EQ(accessor["componentType"], 5126);
  EXPECT_EQ(accessor["count"], count);
  EXPECT_EQ(accessor.value("byteOffset", 0), 0);
  const auto& view = gltf["bufferViews"][accessor["bufferView"].get<int>()];
  EXPECT_EQ(view["buffer"], 0);
  EXPECT_EQ(view["byteLength"], count * components * 4);
  const size_t offset = view.value("byteOffset", size_t(0));
  EXPECT_EQ(offset % 4, 0u);
  std::vector<float> values(count * components);
  if (offset + values.size() * 4 <= bin.size()) std::memcpy(values.data(), bin.data() + offset, values.size() * 4);
  else ADD_FAILURE() << "accessor " << index << " runs past the buffer";
  return values;
}

void CheckGltfAgainstCloud(const nlohmann::json& gltf, const std::string& bin, const GaussianCloud& cloud) {
  const size_t n = cloud.size();
  const int k = cloud.sh_coeffs;
  EXPECT_EQ(gltf["asset"]["version"], "2.0");
  EXPECT_EQ(gltf["extensionsUsed"], nlohmann::json::array({"KHR_gaussian_splatting"}));
  EXPECT_FALSE(gltf.contains("extensionsRequired"));  // fallback to points stays possible
  ASSERT_EQ(gltf["buffers"].size(), 1u);
  const size_t byte_length = gltf["buffers"][0]["byteLength"];
  EXPECT_EQ(byte_length, n * (12 + 4 + 16 + 12 + 4 + 12 * k));
  EXPECT_GE(bin.size(), byte_length);
  EXPECT_LT(bin.size(), byte_length + 4);
  ASSERT_EQ(gltf["meshes"].size(), 1u);
  ASSERT_EQ(gltf["meshes"][0]["primitives"].size(), 1u);
  const auto& primitive = gltf["meshes"][0]["primitives"][0];
  EXPECT_EQ(primitive["mode"], 0);
  const auto& ext = primitive["extensions"]["KHR_gaussian_splatting"];
  EXPECT_EQ(ext["kernel"], "ellipse");
  EXPECT_EQ(ext["colorSpace"], "srgb_rec709_display");
  EXPECT_EQ(gltf["nodes"][0]["mesh"], 0);
  EXPECT_FALSE(gltf["nodes"][0].contains("matrix"));

  std::set<std::string> expected = {"POSITION", "COLOR_0", "KHR_gaussian_splatting:ROTATION",
                                    "KHR_gaussian_splatting:SCALE", "KHR_gaussian_splatting:OPACITY"};
  for (int l = 0; l * l < k; ++l) {
    for (int m = 0; m <= 2 * l; ++m) {
      expected.insert("KHR_gaussian_splatting:SH_DEGREE_" + std::to_string(l) + "_COEF_" + std::to_string(m));
    }
  }
  std::set<std::string> names;
  for (const auto& item : primitive["attributes"].items()) names.insert(item.key());
  EXPECT_EQ(names, expected);
  const auto& attr = primitive["attributes"];

  const std::vector<float> pos = AccessorFloats(gltf, bin, attr["POSITION"], "VEC3", 3, n);
  const std::vector<float> rot = AccessorFloats(gltf, bin, attr["KHR_gaussian_splatting:ROTATION"], "VEC4", 4, n);
  const std::vector<float> scale = AccessorFloats(gltf, bin, attr["KHR_gaussian_splatting:SCALE"], "VEC3", 3, n);
  const std::vector<float> opacity =
      AccessorFloats(gltf, bin, attr["KHR_gaussian_splatting:OPACITY"], "SCALAR", 1, n);
  std::vector<std::vector<float>> sh(k);
  for (int j = 0; j < k; ++j) {
    const int l = static_cast<int>(std::sqrt(j + 0.5));
    sh[j] = AccessorFloats(
        gltf, bin, attr["KHR_gaussian_splatting:SH_DEGREE_" + std::to_string(l) + "_COEF_" + std::to_string(j - l * l)],
        "VEC3", 3, n);
  }
  // COLOR_0: unsigned byte, normalized.
  const auto& color_accessor = gltf["accessors"][attr["COLOR_0"].get<int>()];
  EXPECT_EQ(color_accessor["componentType"], 5121);
  EXPECT_EQ(color_accessor["normalized"], true);
  EXPECT_EQ(color_accessor["type"], "VEC4");
  const size_t color_offset = gltf["bufferViews"][color_accessor["bufferView"].get<int>()].value("byteOffset", 0);

  // POSITION bounds are required by glTF.
  const auto& pos_accessor = gltf["accessors"][attr["POSITION"].get<int>()];
  for (int a = 0; a < 3; ++a) {
    float lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < n; ++i) {
      lo = std::min(lo, pos[3 * i + a]);
      hi = std::max(hi, pos[3 * i + a]);
    }
    EXPECT_EQ(pos_accessor["min"][a].get<double>(), lo);
    EXPECT_EQ(pos_accessor["max"][a].get<double>(), hi);
  }

  const std::vector<double> flip_x = {0, 1, 0, 0};  // 180 degrees about x, (w, x, y, z)
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  for (size_t i = 0; i < n; ++i) {
    // Position: (x, y, z) -> (x, -y, -z).
    EXPECT_EQ(pos[3 * i + 0], cloud.means[3 * i + 0]);
    EXPECT_EQ(pos[3 * i + 1], -cloud.means[3 * i + 1]);
    EXPECT_EQ(pos[3 * i + 2], -cloud.means[3 * i + 2]);
    // Rotation: flip_x * q, stored x y z w.
    const std::vector<double> q = QuatMul(flip_x, UnitQuat(cloud, static_cast<int>(i)));
    EXPECT_NEAR(rot[4 * i + 0], q[1], 1e-6);
    EXPECT_NEAR(rot[4 * i + 1], q[2], 1e-6);
    EXPECT_NEAR(rot[4 * i + 2], q[3], 1e-6);
    EXPECT_NEAR(rot[4 * i + 3], q[0], 1e-6);
    // Scale linear, opacity in [0, 1].
    double s[3], s_cloud[3];
    for (int a = 0; a < 3; ++a) {
      s_cloud[a] = std::exp(double(cloud.log_scales[3 * i + a]));
      EXPECT_NEAR(scale[3 * i + a], s_cloud[a], 1e-6 * s_cloud[a]);
      s[a] = scale[3 * i + a];
    }
    EXPECT_NEAR(opacity[i], SigmoidD(cloud.opacity_logits[i]), 1e-7);
    // The covariance in the glTF frame is R_x Sigma R_x^T (R_x = diag(1, -1, -1)).
    const std::vector<double> uq = UnitQuat(cloud, static_cast<int>(i));
    const std::vector<double> cov_world = Covariance(uq[1], uq[2], uq[3], uq[0], s_cloud);
    const std::vector<double> cov_gltf = Covariance(rot[4 * i], rot[4 * i + 1], rot[4 * i + 2], rot[4 * i + 3], s);
    const double sign[3] = {1, -1, -1};
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        EXPECT_NEAR(cov_gltf[3 * a + b], sign[a] * sign[b] * cov_world[3 * a + b], 1e-5 * (1 + cov_world[0]));
      }
    }
    // SH: the colour seen along world direction d equals the glTF colour
    // along the converted direction (dx, -dy, -dz), for random directions.
    for (int trial = 0; trial < 3; ++trial) {
      double d[3] = {normal(rng), normal(rng), normal(rng)};
      const double norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      for (double& v : d) v /= norm;
      double y_world[16], y_gltf[16];
      kernels::math::Vec3<double> dy[16];
      const int degree = static_cast<int>(std::sqrt(k)) - 1;
      kernels::math::ShBasis(degree, d[0], d[1], d[2], y_world, dy);
      kernels::math::ShBasis(degree, d[0], -d[1], -d[2], y_gltf, dy);
      for (int c = 0; c < 3; ++c) {
        double world = 0, converted = 0;
        for (int j = 0; j < k; ++j) {
          world += y_world[j] * cloud.sh[(i * k + j) * 3 + c];
          converted += y_gltf[j] * sh[j][3 * i + c];
        }
        EXPECT_NEAR(converted, world, 1e-5);
      }
    }
    // COLOR_0: SH base colour and opacity as bytes.
    for (int c = 0; c < 4; ++c) {
      const double expected_value = c < 3 ? std::clamp(0.5 + kC0 * cloud.sh[(i * k) * 3 + c], 0.0, 1.0)
                                          : SigmoidD(cloud.opacity_logits[i]);
      const uint8_t byte = static_cast<uint8_t>(bin[color_offset + 4 * i + c]);
      EXPECT_NEAR(byte / 255.0, expected_value, 0.5 / 255 + 1e-6);
    }
  }
}

TEST(GltfExport, GlbAndGltfHoldTheConvertedCloudForEveryShDegree) {
  const std::string dir = TestTempDir();
  for (int k : {1, 4, 9, 16}) {
    SCOPED_TRACE("sh_coeffs " + std::to_string(k));
    const GaussianCloud cloud = RandomCloud(37, k, 20 + k);
    SaveGltf(cloud, dir + "/map.glb");
    nlohmann::json json;
    std::string bin;
    ParseGlb(ReadAll(dir + "/map.glb"), &json, &bin);
    CheckGltfAgainstCloud(json, bin, cloud);

    // .gltf: the same document with the buffer as a base64 data URI.
    SaveMap(cloud, dir + "/map.gltf");
    const nlohmann::json text = nlohmann::json::parse(ReadAll(dir + "/map.gltf"));
    const std::string uri = text["buffers"][0]["uri"];
    const std::string prefix = "data:application/octet-stream;base64,";
    ASSERT_EQ(uri.compare(0, prefix.size(), prefix), 0);
    const std::string embedded = DecodeBase64(uri.substr(prefix.size()));
    EXPECT_EQ(embedded, bin.substr(0, embedded.size()));
    CheckGltfAgainstCloud(text, embedded, cloud);
  }
}

TEST(GltfExport, RejectsEmptyMapsAndOtherExtensions) {
  const std::string dir = TestTempDir();
  EXPECT_INVALID_INPUT(SaveGltf(GaussianCloud(), dir + "/empty.glb"), "the map has no Gaussians");
  EXPECT_INVALID_INPUT(SaveGltf(RandomCloud(2, 1, 1), dir + "/map.obj"), "must end in .glb");
  GaussianCloud cloud = RandomCloud(3, 1, 1);
  cloud.means[4] = NAN;
  EXPECT_INVALID_INPUT(SaveGltf(cloud, dir + "/nan.glb"), "Gaussian 1 has a non-finite mean");
  EXPECT_TRUE(fs::is_empty(dir));
}

// ---------------------------------------------------------------------------
// glTF import

// The loaded cloud equals `cloud` up to float rounding in log(exp(s)) and
// logit(sigmoid(o)); quaternions come back unit length.
void ExpectGltfRoundTrip(const GaussianCloud& back, const GaussianCloud& cloud) {
  ASSERT_EQ(back.size(), cloud.size());
  ASSERT_EQ(back.sh_coeffs, cloud.sh_coeffs);
  for (int i = 0; i < cloud.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(back.means[3 * i + a], cloud.means[3 * i + a]) << "Gaussian " << i;  // negated twice: exact
      EXPECT_NEAR(back.log_scales[3 * i + a], cloud.log_scales[3 * i + a], 1e-5) << "Gaussian " << i;
    }
    const std::vector<double> q = UnitQuat(cloud, i);
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(back.quats[4 * i + j], q[j], 1e-6) << "Gaussian " << i;
    EXPECT_NEAR(back.opacity_logits[i], cloud.opacity_logits[i], 1e-4) << "Gaussian " << i;
    for (int j = 0; j < 3 * cloud.sh_coeffs; ++j) {
      EXPECT_EQ(back.sh[3 * i * cloud.sh_coeffs + j], cloud.sh[3 * i * cloud.sh_coeffs + j]) << "Gaussian " << i;
    }
  }
}

TEST(GltfImport, RoundTripForEveryShDegreeInBothContainers) {
  const std::string dir = TestTempDir();
  for (int k : {1, 4, 9, 16}) {
    SCOPED_TRACE("sh_coeffs " + std::to_string(k));
    const GaussianCloud cloud = RandomCloud(41, k, 50 + k);
    for (const char* name : {"/map.glb", "/map.gltf"}) {
      SaveMap(cloud, dir + name);
      ExpectGltfRoundTrip(LoadMap(dir + name), cloud);
    }
  }
}

// A .gltf written by dypho, parsed for editing, and written back.
nlohmann::json SavedGltf(const GaussianCloud& cloud, const std::string& path) {
  SaveGltf(cloud, path);
  return nlohmann::json::parse(ReadAll(path));
}

nlohmann::json& Attributes(nlohmann::json& gltf) { return gltf["meshes"][0]["primitives"][0]["attributes"]; }

TEST(GltfImport, WithoutShTheColourComesFromColor0) {
  const std::string dir = TestTempDir();
  const GaussianCloud cloud = RandomCloud(30, 4, 3);
  nlohmann::json gltf = SavedGltf(cloud, dir + "/map.gltf");
  for (int coef = 0; coef < 4; ++coef) {
    const int degree = coef == 0 ? 0 : 1;
    Attributes(gltf).erase("KHR_gaussian_splatting:SH_DEGREE_" + std::to_string(degree) + "_COEF_" +
                           std::to_string(coef == 0 ? 0 : coef - 1));
  }
  WriteAll(dir + "/colour.gltf", gltf.dump());
  const GaussianCloud back = LoadGltf(dir + "/colour.gltf");
  ASSERT_EQ(back.size(), cloud.size());
  EXPECT_EQ(back.sh_coeffs, 1);
  for (int i = 0; i < cloud.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double colour = std::clamp(0.5 + kC0 * cloud.sh[3 * i * 4 + c], 0.0, 1.0);
      EXPECT_NEAR(0.5 + kC0 * back.sh[3 * i + c], colour, 0.5 / 255 + 1e-6) << "Gaussian " << i;
    }
  }
}

TEST(GltfImport, BadFilesAreClearErrors) {
  const std::string dir = TestTempDir();
  const GaussianCloud cloud = RandomCloud(12, 4, 9);
  EXPECT_INVALID_INPUT(LoadMap(dir + "/missing.glb"), "missing.glb: no such file");
  fs::create_directories(dir + "/folder.glb");
  EXPECT_INVALID_INPUT(LoadMap(dir + "/folder.glb"), "folder.glb: no such file");

  SaveGltf(cloud, dir + "/map.glb");
  const std::string glb = ReadAll(dir + "/map.glb");
  WriteAll(dir + "/cut.glb", glb.substr(0, glb.size() / 2));
  EXPECT_INVALID_INPUT(LoadMap(dir + "/cut.glb"), "cut.glb");
  WriteAll(dir + "/text.glb", "this is not glTF");
  EXPECT_INVALID_INPUT(LoadMap(dir + "/text.glb"), "text.glb: not a readable glTF file");

  const nlohmann::json good = SavedGltf(cloud, dir + "/map.gltf");
  struct Case {
    const char* name;
    std::function<void(nlohmann::json&)> edit;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"plain", [](nlohmann::json& g) { Attributes(g).erase("KHR_gaussian_splatting:ROTATION"); },
       "no primitive has the KHR_gaussian_splatting attributes"},
      {"no_opacity", [](nlohmann::json& g) { Attributes(g).erase("KHR_gaussian_splatting:OPACITY"); },
       "has no KHR_gaussian_splatting:OPACITY"},
      {"half_degree", [](nlohmann::json& g) { Attributes(g).erase("KHR_gaussian_splatting:SH_DEGREE_1_COEF_2"); },
       "SH degree 1 has 2 of its 3 coefficients"},
      {"counts",
       [](nlohmann::json& g) {
         const int scale = Attributes(g)["KHR_gaussian_splatting:SCALE"];
         g["accessors"][scale]["count"] = 11;
       },
       "disagree on the number of Gaussians (11 vs 12 positions)"},
      {"overrun",
       [](nlohmann::json& g) {
         const int position = Attributes(g)["POSITION"];
         g["accessors"][position]["byteOffset"] = 64;
       },
       "POSITION: 12 elements reach past the end of their buffer"},
      {"int_scale",
       [](nlohmann::json& g) {
         const int scale = Attributes(g)["KHR_gaussian_splatting:SCALE"];
         g["accessors"][scale]["componentType"] = 5125;  // UNSIGNED_INT
       },
       "SCALE: component type 5125 is not supported"},
      {"scalar_rotation",
       [](nlohmann::json& g) {
         const int rotation = Attributes(g)["KHR_gaussian_splatting:ROTATION"];
         g["accessors"][rotation]["type"] = "SCALAR";
       },
       "ROTATION: expected VEC4, found SCALAR"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    nlohmann::json edited = good;
    c.edit(edited);
    const std::string path = dir + "/" + c.name + ".gltf";
    WriteAll(path, edited.dump());
    EXPECT_INVALID_INPUT(LoadMap(path), c.message);
  }
}

}  // namespace
}  // namespace dypho
