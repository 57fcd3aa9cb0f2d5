// The `dypho` program: dispatches to a subcommand registered in tools/cmd_*.cc.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include <unistd.h>

#include "common/check.h"
#include "common/logging.h"
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

// OpenMP threads that finish a parallel region spin for a while before they
// sleep (libgomp's default). dypho alternates between the rasterizer's and
// LibTorch's parallel regions and often shares the CPU with other busy
// threads; spinning threads then steal the cores the working ones need (a
// mapping step measured 5.5x slower on 2 loaded cores). OMP_WAIT_POLICY is
// read when libgomp loads, before main, so the program sets it and restarts
// itself once. A value the user sets is kept.
void PreferPassiveOpenMpThreads(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr) return;
  setenv("OMP_WAIT_POLICY", "passive", 1);
  execv("/proc/self/exe", argv);  // returns only on failure: continue with the default policy
}

int main(int argc, char** argv) {
  PreferPassiveOpenMpThreads(argv);
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
        // The check's source location only with DYPHO_LOG=debug: a user
        // needs the message (it names the file, key or field).
        std::fprintf(stderr, "dypho %s: error: %s\n", argv[1], e.message().c_str());
        if (!e.location().empty() && dypho::GetLogLevel() <= dypho::LogLevel::kDebug)
          std::fprintf(stderr, "  (%s)\n", e.location().c_str());
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
