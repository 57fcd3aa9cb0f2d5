// Progress for long work: items done, rate and time left, printed to stderr
// at most every `min_interval_s` seconds and once at the end.
#pragma once

#include <chrono>
#include <optional>
#include <string>

namespace dypho {

class Progress {
 public:
  Progress(std::string label, long total, double min_interval_s = 1.0);
  // Marks `n` more items done; prints when due. `extra` is appended.
  void Advance(long n = 1, const std::string& extra = "");
  // Prints the final line (idempotent).
  void Finish(const std::string& extra = "");
  long done() const { return done_; }
  // Work stops at `deadline` whatever is left: "s left" never exceeds it.
  void SetDeadline(std::chrono::steady_clock::time_point deadline) { deadline_ = deadline; }
  // Items per second since construction.
  double Rate() const;
  // A formatted line as printed (exposed for tests).
  std::string Line(const std::string& extra) const;

 private:
  std::string label_;
  long total_;
  long done_ = 0;
  double min_interval_s_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_print_;
  std::optional<std::chrono::steady_clock::time_point> deadline_;
};

}  // namespace dypho
