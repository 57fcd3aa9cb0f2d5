// CPU time of this process's threads, by thread name (Linux /proc/self/task),
// so that a run's report can say where the CPU went: the tracking thread,
// dypho-detect, dypho-map, ... (common/thread_name.h names them).
#pragma once

#include <map>
#include <string>
#include <vector>

namespace dypho {

struct ThreadCpuSample {
  std::string name;
  double cpu_seconds = 0.0;  // user + system since the thread started
};
// Per thread id. Empty where /proc is not there (not Linux).
using ThreadCpuSnapshot = std::map<long, ThreadCpuSample>;

ThreadCpuSnapshot ReadThreadCpu();
// The calling thread's id (the key of ReadThreadCpu's map).
long CurrentThreadId();

struct ThreadCpuUse {
  std::string name;   // thread name; the caller's thread is `caller_name`
  int threads = 0;    // threads of this name that ran between the snapshots
  double cores = 0.0; // CPU seconds between the snapshots / `wall_seconds`
};
// CPU used between two snapshots, summed over the threads of each name
// (a thread that ended in between is not counted), largest first. The thread
// `caller` is reported as `caller_name`.
std::vector<ThreadCpuUse> ThreadCpuBetween(const ThreadCpuSnapshot& before, const ThreadCpuSnapshot& after,
                                           double wall_seconds, long caller, const std::string& caller_name);

}  // namespace dypho
