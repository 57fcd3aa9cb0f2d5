// Text helpers shared by the synthetic sequence writers (sequence_writer.cc,
// shore/shore_writer.cc): frame file names, numbers in YAML, paths.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace dypho::synth_text {

// "%.6f" of a timestamp [s]: the frame's file name without extension.
inline std::string TimestampName(double t) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", t);
  return buf;
}

// Shortest text that reads back to the same double.
inline std::string Number(double v) {
  char buf[64];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof(buf), "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

inline std::string Join(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

}  // namespace dypho::synth_text
