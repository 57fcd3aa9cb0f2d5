#include "common/logging.h"

#include <atomic>
#include <cstdio>
#include <mutex>

namespace dypho {
namespace {
std::atomic<int> g_level{static_cast<int>(LogLevel::kInfo)};
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
