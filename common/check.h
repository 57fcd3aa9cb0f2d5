// Two kinds of checks (as in COLMAP):
//  - DYPHO_CHECK_INPUT(cond) << "message": bad input or options. Throws
//    dypho::InvalidInput whose message names the condition, the source
//    location and whatever the caller streamed (the file, field or value).
//  - DYPHO_CHECK(cond) << "message": a broken internal invariant. Prints and
//    aborts; never used for anything a user can cause.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace dypho {

// Thrown for bad input: missing or corrupt files, wrong sizes, bad options.
// what() is the message followed by the check's location in parentheses;
// message() is what a user needs (the dypho program prints only that), and
// code that adds context and throws again builds on message(), so the
// location is not repeated.
class InvalidInput : public std::runtime_error {
 public:
  explicit InvalidInput(const std::string& message, const std::string& location = "")
      : std::runtime_error(location.empty() ? message : message + " (" + location + ")"),
        message_(message),
        location_(location) {}
  const std::string& message() const { return message_; }
  const std::string& location() const { return location_; }  // "[file.cc:42] check failed: cond", or empty

 private:
  std::string message_, location_;
};

// `text` as it may be shown in a message: bytes outside printable ASCII as
// \xNN, cut after `max_length` characters with "..." (a corrupt header must
// not put control characters or megabytes into a terminal).
std::string Printable(const std::string& text, size_t max_length = 80);

// A timestamp [s] for messages: fixed point with microseconds
// ("1305031102.175304", not "1.30503e+09").
std::string FormatTimestamp(double seconds);

namespace internal {

// Collects a message and throws (or aborts) when destroyed at the end of the
// full expression. Destructor is noexcept(false) on purpose.
class CheckMessage {
 public:
  CheckMessage(const char* file, int line, const char* condition, bool fatal);
  CheckMessage(const CheckMessage&) = delete;
  CheckMessage& operator=(const CheckMessage&) = delete;
  ~CheckMessage() noexcept(false);

  template <typename T>
  CheckMessage& operator<<(const T& value) {
    stream_ << value;
    return *this;
  }

 private:
  std::ostringstream stream_;
  std::string prefix_;
  bool fatal_;
};

// Makes `cond ? (void)0 : Voidify() & CheckMessage(...) << ...` well formed.
struct Voidify {
  void operator&(CheckMessage&) {}
};

}  // namespace internal
}  // namespace dypho

#define DYPHO_CHECK_INPUT(cond)                   \
  (cond) ? (void)0                                \
         : ::dypho::internal::Voidify() &         \
               ::dypho::internal::CheckMessage(__FILE__, __LINE__, #cond, false)

#define DYPHO_CHECK(cond)                         \
  (cond) ? (void)0                                \
         : ::dypho::internal::Voidify() &         \
               ::dypho::internal::CheckMessage(__FILE__, __LINE__, #cond, true)
