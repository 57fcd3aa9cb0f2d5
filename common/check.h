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
class InvalidInput : public std::runtime_error {
 public:
  explicit InvalidInput(const std::string& what) : std::runtime_error(what) {}
};

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
