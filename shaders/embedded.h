// SPIR-V of the GLSL shaders in this folder, compiled at build time by glslc
// (a shader that does not compile fails the build) and embedded in the
// binary as 32-bit word arrays.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace dypho::shaders {

struct Spirv {
  const uint32_t* words = nullptr;
  size_t size_bytes = 0;  // multiple of 4
};

// The shader compiled from `file_name` (e.g. "project.comp"); throws
// std::out_of_range for a name that is not embedded.
Spirv Get(const std::string& file_name);

}  // namespace dypho::shaders
