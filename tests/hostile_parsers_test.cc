// Hostile input to the map readers (issue 16): offsets that wrap around,
// URIs outside the file's folder, counts far beyond the file's size, empty
// maps. Each case once crashed, hung or lost data; each must now be an
// InvalidInput error that names the file and what is wrong.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "common/check.h"
#include "engine/dataset/camera_file.h"
#include "engine/export/export.h"
#include "engine/eval/trajectory.h"
#include "engine/io/image_io.h"
#include "engine/pipeline/pipeline_options.h"
#include "engine/export/gltf.h"
#include "engine/export/ply.h"
#include "engine/export/splat.h"
#include "engine/gaussians.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using ::dypho::testing::TestTempDir;

GaussianCloud SmallCloud(int n) {
  GaussianCloud cloud;
  cloud.sh_coeffs = 1;
  for (int i = 0; i < n; ++i) {
    const float mean[3] = {0.1f * i, 0.2f, 3.0f}, log_scale[3] = {-3, -3, -3}, quat[4] = {1, 0, 0, 0};
    const float sh[3] = {0.5f, 0.1f, -0.2f};
    cloud.Add(mean, log_scale, quat, 1.0f, sh);
  }
  return cloud;
}

std::string ReadAll(const std::string &path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteAll(const std::string &path, const std::string &data) {
  std::ofstream out(path, std::ios::binary);
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
}

// A .gltf written by dypho, as JSON to edit.
nlohmann::json SavedGltf(const std::string &dir) {
  SaveGltf(SmallCloud(4), dir + "/map.gltf");
  return nlohmann::json::parse(ReadAll(dir + "/map.gltf"));
}

std::string Base64Decode(const std::string &in) {
  std::string out;
  unsigned value = 0;
  int bits = -8;
  for (unsigned char c : in) {
    int d;
    if (c >= 'A' && c <= 'Z')
      d = c - 'A';
    else if (c >= 'a' && c <= 'z')
      d = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      d = c - '0' + 52;
    else if (c == '+')
      d = 62;
    else if (c == '/')
      d = 63;
    else
      break;
    value = ((value << 6) | static_cast<unsigned>(d)) & 0xFFFFFFu;
    bits += 6;
    if (bits >= 0) {
      out.push_back(static_cast<char>((value >> bits) & 0xFF));
      bits -= 8;
    }
  }
  return out;
}

// The first buffer moved out of its data URI into a file at `bin` (relative
// to the .gltf's folder `dir`) and the URI set to `uri`.
void MoveBufferToFile(nlohmann::json &gltf, const std::string &dir, const std::string &bin, const std::string &uri) {
  const std::string data_uri = gltf["buffers"][0]["uri"];
  const std::string payload = data_uri.substr(data_uri.find(',') + 1);
  fs::create_directories(fs::path(dir + "/" + bin).parent_path());
  WriteAll(dir + "/" + bin, Base64Decode(payload));
  gltf["buffers"][0]["uri"] = uri;
}

TEST(HostileGltf, BufferViewOffsetThatWrapsAroundIsAnError) {
  const std::string dir = TestTempDir();
  nlohmann::json gltf = SavedGltf(dir);
  // offset + length = 2^64 + 16: wraps to 16, inside the buffer.
  gltf["bufferViews"][0]["byteOffset"] = std::uint64_t(18446744073709551600ull);
  gltf["bufferViews"][0]["byteLength"] = std::uint64_t(32);
  WriteAll(dir + "/bad.gltf", gltf.dump());
  EXPECT_INVALID_INPUT(LoadGltf(dir + "/bad.gltf"), "reaches past the end");
}

TEST(HostileGltf, AccessorOffsetThatWrapsAroundIsAnError) {
  const std::string dir = TestTempDir();
  nlohmann::json gltf = SavedGltf(dir);
  gltf["accessors"][0]["byteOffset"] = std::uint64_t(18446744073709551600ull);
  WriteAll(dir + "/bad.gltf", gltf.dump());
  EXPECT_THROW(LoadGltf(dir + "/bad.gltf"), InvalidInput);
}

TEST(HostileGltf, BufferUnderTheFilesFolderIsRead) {
  const std::string dir = TestTempDir();
  nlohmann::json gltf = SavedGltf(dir);
  MoveBufferToFile(gltf, dir, "data/map.bin", "data/map.bin");
  WriteAll(dir + "/external.gltf", gltf.dump());
  EXPECT_EQ(LoadGltf(dir + "/external.gltf").size(), 4);
}

TEST(HostileGltf, UrisOutsideTheFilesFolderAreRefused) {
  const std::string dir = TestTempDir();
  fs::create_directories(dir + "/inner");
  for (const std::string uri : {"../map.bin", "..%2Fmap.bin", "/etc/passwd"}) {
    nlohmann::json gltf = SavedGltf(dir);
    MoveBufferToFile(gltf, dir, "map.bin", uri);
    if (uri == "/etc/passwd") gltf["buffers"][0]["byteLength"] = 16;
    WriteAll(dir + "/inner/outside.gltf", gltf.dump());
    SCOPED_TRACE(uri);
    // From the root folder too: tinygltf also tries the working folder.
    const fs::path cwd = fs::current_path();
    fs::current_path("/");
    try {
      LoadGltf(dir + "/inner/outside.gltf");
      ADD_FAILURE() << "read a buffer outside the folder";
    } catch (const InvalidInput &e) {
      EXPECT_NE(std::string(e.what()).find("outside the file's folder"), std::string::npos) << e.what();
    }
    fs::current_path(cwd);
  }
}

TEST(HostileGltf, ImagesAreNotDecoded) {
  const std::string dir = TestTempDir();
  nlohmann::json gltf = SavedGltf(dir);
  // Not a PNG: decoding it would fail the load.
  gltf["images"] = nlohmann::json::array({{{"uri", "data:image/png;base64,AAAAAAAAAAAAAAAA"}}});
  WriteAll(dir + "/image.gltf", gltf.dump());
  EXPECT_EQ(LoadGltf(dir + "/image.gltf").size(), 4);
}

TEST(HostileGltf, NanQuaternionIsNamedAsNonFinite) {
  const std::string dir = TestTempDir();
  GaussianCloud cloud = SmallCloud(2);
  cloud.quats[4] = std::nanf("");
  EXPECT_INVALID_INPUT(SaveGltf(cloud, dir + "/nan.glb"), "non-finite");
  EXPECT_INVALID_INPUT(SaveSplat(cloud, dir + "/nan.splat"), "non-finite");
}

// Elements of no properties take no bytes: their count must not be trusted.
TEST(HostilePly, ElementWithoutPropertiesAndAHugeCountIsAnErrorNotAHang) {
  const std::string dir = TestTempDir();
  for (const std::string format : {"ascii", "binary_little_endian"}) {
    SCOPED_TRACE(format);
    WriteAll(dir + "/bad.ply", "ply\nformat " + format +
                                   " 1.0\nelement junk 999999999999999999\nelement vertex 0\n"
                                   "property float x\nend_header\n");
    EXPECT_INVALID_INPUT(LoadPly(dir + "/bad.ply"), "'junk' declares 999999999999999999 records but no properties");
  }
}

TEST(HostilePly, CountsBeyondTheFileSizeAreAnError) {
  const std::string dir = TestTempDir();
  WriteAll(dir + "/bad.ply",
           "ply\nformat ascii 1.0\nelement face 100000000000000000\nproperty list uchar int vertex_indices\n"
           "element vertex 1\nproperty float x\nend_header\n1\n");
  EXPECT_INVALID_INPUT(LoadPly(dir + "/bad.ply"), "truncated or corrupt");
}

TEST(HostilePly, ControlCharactersInTheHeaderAreEscapedInMessages) {
  const std::string dir = TestTempDir();
  WriteAll(dir + "/bad.ply", "ply\nformat \x1b[2Jascii 1.0\nend_header\n");
  try {
    LoadPly(dir + "/bad.ply");
    ADD_FAILURE() << "expected InvalidInput";
  } catch (const InvalidInput& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.find('\x1b'), std::string::npos) << message;
    EXPECT_NE(message.find("\\x1b[2Jascii"), std::string::npos) << message;
  }
  EXPECT_EQ(Printable(std::string(500, 'a')).size(), 83u);
}

TEST(HostilePng, SizeIsCheckedInTheHeaderBeforeDecoding) {
  const std::string dir = TestTempDir();
  // Signature and an IHDR chunk of a 30000 x 30000 RGB image, nothing else.
  const unsigned char header[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R',
                                  0,    0,   0x75, 0x30, 0, 0, 0x75, 0x30, 8, 2, 0, 0, 0, 0, 0, 0, 0};
  WriteAll(dir + "/huge.png", std::string(reinterpret_cast<const char*>(header), sizeof(header)));
  EXPECT_INVALID_INPUT(ReadRgb8(dir + "/huge.png"), "is 30000x30000 pixels: larger than dypho reads");
}

TEST(HostileConfig, NumberThatUnderflowsToZeroIsAnError) {
  PipelineOptions options;
  // finish_seconds = 0 means "no limit": 1e-400 must not become that.
  EXPECT_INVALID_INPUT(ApplyConfigText(&options, "finish_seconds: 1e-400\n", "c.yaml"), "too small for a double");
  EXPECT_INVALID_INPUT(SetOption(&options, "finish_seconds", "1e-400", "--set"), "finish_seconds: '1e-400'");
}

TEST(HostileConfig, DuplicateKeysAreAnError) {
  PipelineOptions options;
  EXPECT_INVALID_INPUT(ApplyConfigText(&options, "sequential: true\nsequential: false\n", "c.yaml"),
                       "c.yaml: key 'sequential' is given twice");
  EXPECT_INVALID_INPUT(ApplyConfigText(&options, "mapper:\n  num_threads: 2\nmapper:\n  num_threads: 3\n", "c.yaml"),
                       "key 'mapper.num_threads' is given twice");
  EXPECT_INVALID_INPUT(ApplyConfigText(&options, "{\"sequential\": true, \"sequential\": false}", "c.json"),
                       "given twice");
}

TEST(HostileConfig, DeepNestingIsNamed) {
  PipelineOptions options;
  std::string text;
  for (int i = 0; i < 40; ++i) text += std::string(2 * i, ' ') + "a" + std::to_string(i) + ":\n";
  text += std::string(80, ' ') + "x: 1\n";
  EXPECT_INVALID_INPUT(ApplyConfigText(&options, text, "c.yaml"), "nested deeper than");
  // Flow style: yaml-cpp alone said "bad file".
  EXPECT_INVALID_INPUT(ApplyConfigText(&options, "a: " + std::string(5000, '[') + std::string(5000, ']'), "c.yaml"),
                       "c.yaml: lists or maps nested 5000 deep");
}

TEST(HostileMessages, TimestampsArePrintedInFull) {
  const std::string dir = TestTempDir();
  WriteAll(dir + "/t.txt", "1305031102.2 0 0 0 0 0 0 1\n1305031102.1 0 0 0 0 0 0 1\n");
  EXPECT_INVALID_INPUT(ReadTumTrajectory(dir + "/t.txt"), "timestamp 1305031102.100000 does not increase");
  WriteAll(dir + "/t.txt", "1305031102.2 0 0 0 0 0 0 1\n\x1b[2J 0 0\n");
  EXPECT_INVALID_INPUT(ReadTumTrajectory(dir + "/t.txt"), "got '\\x1b[2J 0 0'");
}

TEST(HostileCamera, IntrinsicsOffTheImageAreAnErrorNamingFileAndField) {
  const std::string dir = TestTempDir();
  const std::string sane = "fx: 525\nfy: 525\nwidth: 640\nheight: 480\n";
  struct Case {
    std::string values, field;
  };
  for (const Case& c : std::vector<Case>{{"cx: 1e9\ncy: 240\n", "cx"},
                                         {"cx: 1e8\ncy: 240\n", "cx"},
                                         {"cx: -1e9\ncy: 240\n", "cx"},
                                         {"cx: 320\ncy: 481\n", "cy"}}) {
    WriteAll(dir + "/camera.yaml", sane + c.values);
    SCOPED_TRACE(c.values);
    EXPECT_INVALID_INPUT(ReadCameraFile(dir + "/camera.yaml"),
                         "camera.yaml: camera " + c.field + " must lie on the image");
  }
  WriteAll(dir + "/camera.yaml", "fx: 1e-9\nfy: 525\ncx: 320\ncy: 240\nwidth: 640\nheight: 480\n");
  EXPECT_INVALID_INPUT(ReadCameraFile(dir + "/camera.yaml"), "camera.yaml: camera fx must be in");
  WriteAll(dir + "/camera.yaml", "fx: 525\nfy: 525\ncx: 319.5\ncy: 239.5\nwidth: 640\nheight: 480\n");
  EXPECT_EQ(ReadCameraFile(dir + "/camera.yaml").camera.cx, 319.5);
}

}  // namespace
}  // namespace dypho
