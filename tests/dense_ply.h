// Reads the dense map's export (dense.ply: x y z nx ny nz red green blue,
// binary little-endian) for tests that check its points.
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "engine/export/point_cloud.h"

namespace dypho::testing {

inline ColoredPoints ReadDensePly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in.good()) << path;
  std::string line, header;
  int n = -1;
  while (std::getline(in, line) && line != "end_header") {
    header += line + "\n";
    if (line.rfind("element vertex ", 0) == 0) n = std::stoi(line.substr(15));
  }
  EXPECT_NE(header.find("property float nx\nproperty float ny\nproperty float nz\nproperty uchar red"),
            std::string::npos)
      << header;
  ColoredPoints p;
  std::vector<char> row(27);
  for (int i = 0; i < n && in.read(row.data(), 27); ++i) {
    float f[6];
    std::memcpy(f, row.data(), 24);
    p.xyz.insert(p.xyz.end(), f, f + 3);
    p.normals.insert(p.normals.end(), f + 3, f + 6);
    p.rgb.insert(p.rgb.end(), row.data() + 24, row.data() + 27);
  }
  EXPECT_EQ(p.size(), n);
  return p;
}

}  // namespace dypho::testing
