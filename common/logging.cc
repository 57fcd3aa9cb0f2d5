#include "common/logging.h"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>

namespace dypho {
namespace {
// The start-up level comes from the environment variable DYPHO_LOG
// (debug|info|warning|error|silent); info when unset or unknown.
int InitialLevel() {
  const char* env = std::getenv("DYPHO_LOG");
  if (env == nullptr) return static_cast<int>(LogLevel::kInfo);
  const char* names[] = {"debug", "info", "warning", "error", "silent"};
  for (int i = 0; i < 5; ++i) {
    if (std::strcmp(env, names[i]) == 0) return i;
  }
  return static_cast<int>(LogLevel::kInfo);
}
std::atomic<int> g_level{InitialLevel()};
std::mutex g_mutex;
const char* Tag(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug: return "D";
    case LogLevel::kInfo: return "I";
    case LogLevel::kWarning: return "W";
    case LogLevel::kError: return "E";
    default: return "?";
  }
}
}  // namespace

void SetLogLevel(LogLevel level) { g_level = static_cast<int>(level); }
LogLevel GetLogLevel() { return static_cast<LogLevel>(g_level.load()); }

namespace internal {
LogMessage::LogMessage(LogLevel level, const char*, int) : level_(level) {}
LogMessage::~LogMessage() {
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "[dypho %s] %s\n", Tag(level_), stream_.str().c_str());
  std::fflush(stderr);
}
}  // namespace internal
}  // namespace dypho
