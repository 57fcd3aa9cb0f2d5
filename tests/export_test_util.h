// Helpers shared by the export tests (export_ply_test.cc, export_gltf_test.cc,
// export_test.cc): an awkward random cloud, whole-file reads and writes, a
// bit-exact cloud comparison and an independent split of a PLY file.
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "engine/gaussians.h"

namespace dypho::export_testing {

// A cloud with every value distinct and a few awkward floats (negative zero,
// a denormal, unnormalised quaternions) so that a swapped field or a lossy
// copy shows.
inline GaussianCloud RandomCloud(int n, int sh_coeffs, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  GaussianCloud cloud;
  cloud.sh_coeffs = sh_coeffs;
  for (int i = 0; i < n; ++i) {
    float mean[3] = {u(rng), u(rng), u(rng) + 3.0f};
    float log_scale[3] = {u(rng) - 3.0f, u(rng) - 3.0f, u(rng) - 3.0f};
    float quat[4] = {u(rng), u(rng), u(rng), u(rng)};
    std::vector<float> coeffs(3 * sh_coeffs);
    for (float& c : coeffs) c = u(rng);
    cloud.Add(mean, log_scale, quat, u(rng) * 3.0f, coeffs.data());
  }
  if (n > 1) {
    cloud.means[1] = -0.0f;
    cloud.sh[2] = std::numeric_limits<float>::denorm_min();
  }
  return cloud;
}

inline std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void WriteAll(const std::string& path, const std::string& data) {
  std::ofstream out(path, std::ios::binary);
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
}

inline bool SameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

inline void ExpectSameCloud(const GaussianCloud& a, const GaussianCloud& b) {
  EXPECT_EQ(a.sh_coeffs, b.sh_coeffs);
  EXPECT_TRUE(SameBits(a.means, b.means));
  EXPECT_TRUE(SameBits(a.log_scales, b.log_scales));
  EXPECT_TRUE(SameBits(a.quats, b.quats));
  EXPECT_TRUE(SameBits(a.opacity_logits, b.opacity_logits));
  EXPECT_TRUE(SameBits(a.sh, b.sh));
}

// ---------------------------------------------------------------------------
// An independent PLY reader: header lines as text, body as raw floats.
struct TestPly {
  std::vector<std::string> header_lines;
  std::string body;
};

inline TestPly SplitPly(const std::string& data) {
  TestPly ply;
  size_t pos = 0;
  while (true) {
    const size_t eol = data.find('\n', pos);
    if (eol == std::string::npos) ADD_FAILURE() << "no end_header";
    if (eol == std::string::npos) return ply;
    ply.header_lines.push_back(data.substr(pos, eol - pos));
    pos = eol + 1;
    if (ply.header_lines.back() == "end_header") break;
  }
  ply.body = data.substr(pos);
  return ply;
}

}  // namespace dypho::export_testing
