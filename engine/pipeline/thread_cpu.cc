#include "engine/pipeline/thread_cpu.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#if defined(__linux__)
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace dypho {

ThreadCpuSnapshot ReadThreadCpu() {
  ThreadCpuSnapshot out;
#if defined(__linux__)
  const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/task", ec)) {
    std::ifstream f(entry.path() / "stat");
    std::string line;
    if (!std::getline(f, line)) continue;  // the thread ended meanwhile
    // "tid (name) state ...": the name may hold spaces and parentheses.
    const size_t open = line.find('('), close = line.rfind(')');
    if (open == std::string::npos || close == std::string::npos || close < open) continue;
    std::istringstream rest(line.substr(close + 2));
    std::string field;
    long utime = 0, stime = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i) {  // fields 14 and 15: utime, stime
      if (i == 14) utime = std::stol(field);
      if (i == 15) stime = std::stol(field);
    }
    ThreadCpuSample s;
    s.name = line.substr(open + 1, close - open - 1);
    s.cpu_seconds = (utime + stime) / ticks;
    out[std::stol(line.substr(0, open))] = s;
  }
#endif
  return out;
}

long CurrentThreadId() {
#if defined(__linux__)
  return static_cast<long>(syscall(SYS_gettid));
#else
  return 0;
#endif
}

std::vector<ThreadCpuUse> ThreadCpuBetween(const ThreadCpuSnapshot& before, const ThreadCpuSnapshot& after,
                                           double wall_seconds, long caller, const std::string& caller_name) {
  std::map<std::string, ThreadCpuUse> by_name;
  for (const auto& [tid, s] : after) {
    const auto b = before.find(tid);
    const double used = s.cpu_seconds - (b != before.end() ? b->second.cpu_seconds : 0.0);
    if (used <= 0.0) continue;
    const std::string name = tid == caller ? caller_name : s.name;
    ThreadCpuUse& u = by_name[name];
    u.name = name;
    ++u.threads;
    u.cores += wall_seconds > 0 ? used / wall_seconds : 0.0;
  }
  std::vector<ThreadCpuUse> out;
  for (auto& [name, u] : by_name) out.push_back(u);
  std::sort(out.begin(), out.end(), [](const ThreadCpuUse& a, const ThreadCpuUse& b) { return a.cores > b.cores; });
  return out;
}

}  // namespace dypho
