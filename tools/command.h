// Subcommands of the `dypho` program. Each tools/cmd_*.cc defines one or more
// `int Run...(int argc, char** argv)` functions and registers them with
// DYPHO_COMMAND; the function only parses flags (CLI11) and calls library code.
#pragma once

#include <string>
#include <vector>

namespace dypho::tools {

using CommandFn = int (*)(int argc, char** argv);

struct Command {
  std::string name;
  std::string summary;
  CommandFn run;
};

std::vector<Command>& Commands();

struct CommandRegistrar {
  CommandRegistrar(const char* name, const char* summary, CommandFn run) {
    Commands().push_back({name, summary, run});
  }
};

}  // namespace dypho::tools

#define DYPHO_COMMAND_CAT2(a, b) a##b
#define DYPHO_COMMAND_CAT(a, b) DYPHO_COMMAND_CAT2(a, b)
#define DYPHO_COMMAND(name, summary, fn)                        \
  static ::dypho::tools::CommandRegistrar DYPHO_COMMAND_CAT(    \
      dypho_command_registrar_, __LINE__)(name, summary, fn)
