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

// --depth-time (DatasetOptions::depth_time) for a command that opens an
// RGB-D dataset; OpenDataset rejects a bad value naming depth_time.
inline CLI::Option* AddDepthTimeOption(CLI::App& app, std::string* value) {
  return app
      .add_option("--depth-time", *value,
                  "when the depth images were captured: auto (the camera preset's offset from the colour "
                  "timestamp, freiburg1 -0.020 s; else the listed timestamps), listed, or an offset [s] from the "
                  "colour timestamp")
      ->capture_default_str();
}

}  // namespace dypho::tools
