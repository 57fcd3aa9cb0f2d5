// The 3DGS PLY export and import, checked by a reader written here from the
// format description: bit-exact round trips for every SH degree, foreign
// files (other property orders, types, elements, ASCII bodies), bad input.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "common/check.h"
#include "engine/export/ply.h"
#include "engine/gaussians.h"
#include "kernels/math/sh.h"
#include "tests/export_test_util.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using ::dypho::testing::TestTempDir;
using export_testing::ExpectSameCloud;
using export_testing::RandomCloud;
using export_testing::ReadAll;
using export_testing::SplitPly;
using export_testing::TestPly;
using export_testing::WriteAll;

float FloatAt(const std::string& body, size_t index) {
  float v;
  std::memcpy(&v, body.data() + 4 * index, 4);
  return v;
}

// Property names of the 3DGS layout for K SH coefficients, in file order.
std::vector<std::string> ExpectedProperties(int k) {
  std::vector<std::string> names = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
  for (int j = 0; j < 3 * (k - 1); ++j) names.push_back("f_rest_" + std::to_string(j));
  for (const char* n : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"}) {
    names.push_back(n);
  }
  return names;
}

TEST(PlyExport, HeaderAndBodyMatchThe3dgsLayout) {
  const std::string dir = TestTempDir();
  for (int k : {1, 4, 9, 16}) {
    SCOPED_TRACE("sh_coeffs " + std::to_string(k));
    const int n = 7;
    const GaussianCloud cloud = RandomCloud(n, k, 10 + k);
    const std::string path = dir + "/map.ply";
    SavePly(cloud, path);
    const TestPly ply = SplitPly(ReadAll(path));
    const std::vector<std::string> names = ExpectedProperties(k);
    ASSERT_EQ(ply.header_lines.size(), 3 + names.size() + 1);
    EXPECT_EQ(ply.header_lines[0], "ply");
    EXPECT_EQ(ply.header_lines[1], "format binary_little_endian 1.0");
    EXPECT_EQ(ply.header_lines[2], "element vertex 7");
    for (size_t j = 0; j < names.size(); ++j) EXPECT_EQ(ply.header_lines[3 + j], "property float " + names[j]);
    EXPECT_EQ(ply.header_lines.back(), "end_header");
    const size_t stride = names.size();  // floats per vertex: 17 + 3 (K - 1)
    EXPECT_EQ(stride, 17u + 3u * (k - 1));
    ASSERT_EQ(ply.body.size(), n * stride * 4);
    for (int i = 0; i < n; ++i) {
      const size_t base = i * stride;
      for (int a = 0; a < 3; ++a) EXPECT_EQ(FloatAt(ply.body, base + a), cloud.means[3 * i + a]);
      for (int a = 3; a < 6; ++a) EXPECT_EQ(FloatAt(ply.body, base + a), 0.0f);
      for (int c = 0; c < 3; ++c) EXPECT_EQ(FloatAt(ply.body, base + 6 + c), cloud.sh[(i * k + 0) * 3 + c]);
      // f_rest_{c (K-1) + (k'-1)} = coefficient k' of channel c.
      for (int c = 0; c < 3; ++c) {
        for (int kk = 1; kk < k; ++kk) {
          EXPECT_EQ(FloatAt(ply.body, base + 9 + c * (k - 1) + (kk - 1)), cloud.sh[(i * k + kk) * 3 + c]);
        }
      }
      const size_t o = base + 9 + 3 * (k - 1);
      EXPECT_EQ(FloatAt(ply.body, o), cloud.opacity_logits[i]);
      for (int a = 0; a < 3; ++a) EXPECT_EQ(FloatAt(ply.body, o + 1 + a), cloud.log_scales[3 * i + a]);
      for (int a = 0; a < 4; ++a) EXPECT_EQ(FloatAt(ply.body, o + 4 + a), cloud.quats[4 * i + a]);
    }
  }
}

TEST(PlyExport, RoundTripIsBitExactForEveryShDegree) {
  const std::string dir = TestTempDir();
  for (int k : {1, 4, 9, 16}) {
    SCOPED_TRACE("sh_coeffs " + std::to_string(k));
    const GaussianCloud cloud = RandomCloud(257, k, 100 + k);
    SavePly(cloud, dir + "/map.ply");
    ExpectSameCloud(LoadPly(dir + "/map.ply"), cloud);
  }
}

TEST(PlyExport, EmptyCloudIsAValidEmptyMap) {
  const std::string dir = TestTempDir();
  GaussianCloud empty;
  empty.sh_coeffs = 16;
  SavePly(empty, dir + "/empty.ply");
  const TestPly ply = SplitPly(ReadAll(dir + "/empty.ply"));
  EXPECT_EQ(ply.header_lines[2], "element vertex 0");
  EXPECT_TRUE(ply.body.empty());
  const GaussianCloud loaded = LoadPly(dir + "/empty.ply");
  EXPECT_TRUE(loaded.empty());
  EXPECT_EQ(loaded.sh_coeffs, 16);  // 45 f_rest properties in the header
}

TEST(PlyExport, SaveRejectsNonFiniteValuesAndWritesNothing) {
  const std::string dir = TestTempDir();
  GaussianCloud cloud = RandomCloud(5, 4, 3);
  cloud.opacity_logits[3] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_INVALID_INPUT(SavePly(cloud, dir + "/bad.ply"), "Gaussian 3 has a non-finite opacity_logit");
  cloud = RandomCloud(5, 4, 3);
  cloud.sh[4 * 3 * 2 + 5] = std::numeric_limits<float>::infinity();
  EXPECT_INVALID_INPUT(SavePly(cloud, dir + "/bad.ply"), "Gaussian 2 has a non-finite SH coefficient");
  cloud = RandomCloud(5, 4, 3);
  cloud.quats.pop_back();
  EXPECT_INVALID_INPUT(SavePly(cloud, dir + "/bad.ply"), "quats has 19 values, expected 20");
  EXPECT_TRUE(fs::is_empty(dir)) << "no partial or temporary file may remain";
}

// ---------------------------------------------------------------------------
// Files from other tools: any order, extra properties and elements, other
// scalar types, ASCII.

struct ForeignProperty {
  std::string type;  // "float", "double", "uchar", ...
  std::string name;
};

// Writes a binary little-endian PLY with one vertex element (and optionally
// a fixed-size element before it), values given as doubles per vertex.
std::string ForeignPly(const std::vector<ForeignProperty>& props, const std::vector<std::vector<double>>& rows,
                       bool camera_element_first = false) {
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment made by another tool\n";
  if (camera_element_first) out += "element camera 2\nproperty double fx\nproperty uchar id\n";
  out += "element vertex " + std::to_string(rows.size()) + "\n";
  for (const auto& p : props) out += "property " + p.type + " " + p.name + "\n";
  out += "end_header\n";
  if (camera_element_first) out += std::string(2 * 9, '\x07');
  for (const auto& row : rows) {
    for (size_t j = 0; j < props.size(); ++j) {
      char bytes[8];
      size_t size = 4;
      if (props[j].type == "float") {
        const float f = static_cast<float>(row[j]);
        std::memcpy(bytes, &f, 4);
      } else if (props[j].type == "double") {
        std::memcpy(bytes, &row[j], 8);
        size = 8;
      } else if (props[j].type == "uchar") {
        bytes[0] = static_cast<char>(static_cast<uint8_t>(row[j]));
        size = 1;
      } else if (props[j].type == "int") {
        const int32_t v = static_cast<int32_t>(row[j]);
        std::memcpy(bytes, &v, 4);
      } else {
        ADD_FAILURE() << "test writer lacks type " << props[j].type;
      }
      out.append(bytes, size);
    }
  }
  return out;
}

TEST(PlyImport, AcceptsAnyOrderExtraPropertiesOtherTypesAndElements) {
  const std::string dir = TestTempDir();
  // Degree 1 (9 f_rest), shuffled, with extras of several types.
  std::vector<ForeignProperty> props = {{"float", "rot_3"},   {"uchar", "red"},     {"double", "x"},
                                        {"float", "scale_2"}, {"float", "f_dc_1"},  {"int", "label"},
                                        {"float", "y"},       {"float", "opacity"}, {"double", "z"},
                                        {"float", "rot_0"},   {"float", "rot_1"},   {"float", "rot_2"},
                                        {"float", "scale_0"}, {"float", "scale_1"}, {"float", "f_dc_0"},
                                        {"float", "f_dc_2"}};
  for (int j = 8; j >= 0; --j) props.push_back({"float", "f_rest_" + std::to_string(j)});
  std::vector<std::vector<double>> rows;
  for (int i = 0; i < 3; ++i) {
    std::vector<double> row(props.size());
    for (size_t j = 0; j < props.size(); ++j) row[j] = 0.25 * (i + 1) + 0.001 * j;
    row[1] = 200;  // red
    row[5] = -7;   // label
    rows.push_back(row);
  }
  WriteAll(dir + "/foreign.ply", ForeignPly(props, rows, /*camera_element_first=*/true));
  const GaussianCloud cloud = LoadPly(dir + "/foreign.ply");
  ASSERT_EQ(cloud.size(), 3);
  EXPECT_EQ(cloud.sh_coeffs, 4);
  auto value = [&](int i, const std::string& name) {
    for (size_t j = 0; j < props.size(); ++j) {
      if (props[j].name == name) return static_cast<float>(rows[i][j]);
    }
    ADD_FAILURE() << name;
    return 0.0f;
  };
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(cloud.means[3 * i + 0], value(i, "x"));
    EXPECT_EQ(cloud.means[3 * i + 1], value(i, "y"));
    EXPECT_EQ(cloud.means[3 * i + 2], value(i, "z"));
    for (int a = 0; a < 3; ++a) EXPECT_EQ(cloud.log_scales[3 * i + a], value(i, "scale_" + std::to_string(a)));
    for (int a = 0; a < 4; ++a) EXPECT_EQ(cloud.quats[4 * i + a], value(i, "rot_" + std::to_string(a)));
    EXPECT_EQ(cloud.opacity_logits[i], value(i, "opacity"));
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(cloud.sh[(i * 4 + 0) * 3 + c], value(i, "f_dc_" + std::to_string(c)));
      for (int kk = 1; kk < 4; ++kk) {
        EXPECT_EQ(cloud.sh[(i * 4 + kk) * 3 + c], value(i, "f_rest_" + std::to_string(c * 3 + kk - 1)));
      }
    }
  }
}

TEST(PlyImport, ReadsAsciiBodies) {
  const std::string dir = TestTempDir();
  std::string text = "ply\nformat ascii 1.0\nelement vertex 2\n";
  const std::vector<std::string> names = ExpectedProperties(1);
  for (const auto& n : names) text += "property float " + n + "\n";
  text += "end_header\n";
  for (int i = 0; i < 2; ++i) {
    for (size_t j = 0; j < names.size(); ++j) text += std::to_string(i * 100 + j) + ".5 ";
    text += "\n";
  }
  WriteAll(dir + "/ascii.ply", text);
  const GaussianCloud cloud = LoadPly(dir + "/ascii.ply");
  ASSERT_EQ(cloud.size(), 2);
  EXPECT_EQ(cloud.means[3], 100.5f);
  EXPECT_EQ(cloud.sh[3 + 2], 108.5f);         // f_dc_2 of vertex 1 is column 8
  EXPECT_EQ(cloud.opacity_logits[1], 109.5f);
  EXPECT_EQ(cloud.quats[7], 116.5f);          // rot_3, the last column
}

TEST(PlyImport, ErrorsNameTheFileAndTheProblem) {
  const std::string dir = TestTempDir();
  const std::string good = dir + "/good.ply";
  SavePly(RandomCloud(10, 4, 1), good);
  const std::string bytes = ReadAll(good);

  EXPECT_INVALID_INPUT(LoadPly(dir + "/missing.ply"), "missing.ply: no such file");

  WriteAll(dir + "/magic.ply", "PLY" + bytes.substr(3));
  EXPECT_INVALID_INPUT(LoadPly(dir + "/magic.ply"), "magic.ply: not a PLY file");
  WriteAll(dir + "/text.ply", "hello world\n");
  EXPECT_INVALID_INPUT(LoadPly(dir + "/text.ply"), "text.ply: not a PLY file");

  WriteAll(dir + "/truncated.ply", bytes.substr(0, bytes.size() - 13));
  EXPECT_INVALID_INPUT(LoadPly(dir + "/truncated.ply"), "(vertex 9 is incomplete)");
  WriteAll(dir + "/no_body.ply", bytes.substr(0, bytes.find("end_header")));
  EXPECT_INVALID_INPUT(LoadPly(dir + "/no_body.ply"), "no 'end_header'");
  WriteAll(dir + "/longer.ply", bytes + std::string(8, '\0'));
  EXPECT_INVALID_INPUT(LoadPly(dir + "/longer.ply"), "8 bytes after the last element");

  std::string big = bytes;
  big.replace(big.find("binary_little_endian"), 20, "binary_big_endian");
  WriteAll(dir + "/big.ply", big);
  EXPECT_INVALID_INPUT(LoadPly(dir + "/big.ply"), "big.ply: binary_big_endian PLY is not supported");

  WriteAll(dir + "/xyz.ply", ForeignPly({{"float", "x"}, {"float", "y"}, {"float", "z"}}, {{1, 2, 3}}));
  EXPECT_INVALID_INPUT(LoadPly(dir + "/xyz.ply"),
                       "xyz.ply: not a 3D Gaussian splatting PLY: vertex element lacks the required properties: "
                       "f_dc_0 f_dc_1 f_dc_2 opacity scale_0 scale_1 scale_2 rot_0 rot_1 rot_2 rot_3");

  // Five f_rest: not a whole SH degree.
  std::vector<ForeignProperty> props;
  for (const auto& n : ExpectedProperties(1)) props.push_back({"float", n});
  for (int j = 0; j < 5; ++j) props.push_back({"float", "f_rest_" + std::to_string(j)});
  WriteAll(dir + "/rest.ply", ForeignPly(props, {std::vector<double>(props.size(), 0.5)}));
  EXPECT_INVALID_INPUT(LoadPly(dir + "/rest.ply"), "5 f_rest properties; expected 0, 9, 24 or 45");

  // NaN and infinity, in the binary body and in ASCII: the vertex is named.
  std::string nan_bytes = bytes;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const size_t stride = 4 * (17 + 9);
  const size_t body = bytes.size() - 10 * stride;
  std::memcpy(&nan_bytes[body + 6 * stride + 4 * 18], &nan, 4);  // vertex 6, float 18 = opacity
  WriteAll(dir + "/nan.ply", nan_bytes);
  EXPECT_INVALID_INPUT(LoadPly(dir + "/nan.ply"), "nan.ply: vertex 6 property 'opacity' is nan");
  std::vector<std::vector<double>> rows = {std::vector<double>(props.size() - 5, 0.0)};
  rows[0][1] = 1e300;  // y: a finite double, infinite as float
  props.resize(props.size() - 5);
  props[1].type = "double";
  WriteAll(dir + "/inf.ply", ForeignPly(props, rows));
  EXPECT_INVALID_INPUT(LoadPly(dir + "/inf.ply"), "inf.ply: vertex 0 property 'y' is inf");

  std::string header = "ply\nformat ascii 1.0\nelement vertex 1\n";
  for (const auto& n : ExpectedProperties(1)) header += "property float " + n + "\n";
  header += "end_header\n";
  WriteAll(dir + "/ascii_nan.ply", header + "0 0 0 0 0 0 1 1 1 nan 0 0 0 1 0 0 0\n");
  EXPECT_INVALID_INPUT(LoadPly(dir + "/ascii_nan.ply"), "vertex 0 property 'opacity' is nan");
  WriteAll(dir + "/ascii_short.ply", header + "0 0 0 0 0 0 1 1 1\n");
  EXPECT_INVALID_INPUT(LoadPly(dir + "/ascii_short.ply"), "body ends in vertex 0");

  WriteAll(dir + "/count.ply", "ply\nformat binary_little_endian 1.0\nelement vertex -3\nend_header\n");
  EXPECT_INVALID_INPUT(LoadPly(dir + "/count.ply"), "non-negative integer count");
}

}  // namespace
}  // namespace dypho
