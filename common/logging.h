// One small logging header. Library code logs at INFO; tools choose the
// verbosity with SetLogLevel; the environment variable DYPHO_LOG
// (debug|info|warning|error|silent) sets the start-up level. Messages go to
// stderr, one line each.
#pragma once

#include <sstream>
#include <string>

namespace dypho {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3, kSilent = 4 };

void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();

namespace internal {
class LogMessage {
 public:
  LogMessage(LogLevel level, const char* file, int line);
  ~LogMessage();
  template <typename T>
  LogMessage& operator<<(const T& value) {
    stream_ << value;
    return *this;
  }

 private:
  LogLevel level_;
  std::ostringstream stream_;
};
}  // namespace internal
}  // namespace dypho

#define DYPHO_LOG(level)                                                  \
  if (::dypho::LogLevel::k##level < ::dypho::GetLogLevel()) {            \
  } else                                                                  \
    ::dypho::internal::LogMessage(::dypho::LogLevel::k##level, __FILE__, __LINE__)
