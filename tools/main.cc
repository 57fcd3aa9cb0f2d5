// The `dypho` program: dispatches to a subcommand registered in tools/cmd_*.cc.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "common/check.h"
#include "tools/command.h"

namespace dypho::tools {
std::vector<Command>& Commands() {
  static std::vector<Command> commands;
  return commands;
}
}  // namespace dypho::tools

namespace {
void PrintUsage() {
  auto commands = dypho::tools::Commands();
  std::sort(commands.begin(), commands.end(),
            [](const auto& a, const auto& b) { return a.name < b.name; });
  std::printf("usage: dypho <command> [options]   (dypho <command> --help for its options)\n\ncommands:\n");
  for (const auto& c : commands) std::printf("  %-12s %s\n", c.name.c_str(), c.summary.c_str());
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
      !std::strcmp(argv[1], "help")) {
    PrintUsage();
    return argc < 2 ? 1 : 0;
  }
  for (const auto& c : dypho::tools::Commands()) {
    if (c.name == argv[1]) {
      try {
        return c.run(argc - 1, argv + 1);
      } catch (const dypho::InvalidInput& e) {
        std::fprintf(stderr, "dypho %s: error: %s\n", argv[1], e.what());
        return 2;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "dypho %s: error: %s\n", argv[1], e.what());
        return 3;
      }
    }
  }
  std::fprintf(stderr, "dypho: unknown command '%s'\n\n", argv[1]);
  PrintUsage();
  return 1;
}
