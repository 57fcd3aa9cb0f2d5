// CLI11 checks shared by the subcommands.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

namespace dypho::tools {

// For a flag naming an output file or folder: an empty value is an error
// (`--out ""` once wrote map.ply and report.md into the filesystem root).
inline CLI::Validator NonEmptyPath() {
  return CLI::Validator(
      [](std::string& value) {
        return value.empty() ? std::string("an output path must not be empty") : std::string();
      },
      "PATH", "NON_EMPTY_PATH");
}

}  // namespace dypho::tools
