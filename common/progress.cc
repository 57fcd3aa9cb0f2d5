#include "common/progress.h"

#include <algorithm>
#include <cstdio>
#include <sstream>
#include <iomanip>

#include "common/logging.h"

namespace dypho {

Progress::Progress(std::string label, long total, double min_interval_s)
    : label_(std::move(label)), total_(total), min_interval_s_(min_interval_s) {
  start_ = last_print_ = std::chrono::steady_clock::now();
}

double Progress::Rate() const {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  return elapsed > 0 ? done_ / elapsed : 0.0;
}

std::string Progress::Line(const std::string& extra) const {
  std::ostringstream s;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  s << label_ << ": " << done_;
  if (total_ > 0) s << "/" << total_;
  s << std::fixed << std::setprecision(1) << " (" << Rate() << "/s, " << elapsed << " s";
  if (total_ > 0 && done_ > 0 && done_ < total_) {
    double left = elapsed / done_ * (total_ - done_);
    if (deadline_)
      left = std::max(0.0, std::min(left, std::chrono::duration<double>(*deadline_ - std::chrono::steady_clock::now()).count()));
    s << ", " << left << " s left";
  }
  s << ")";
  if (!extra.empty()) s << " " << extra;
  return s.str();
}

void Progress::Advance(long n, const std::string& extra) {
  done_ += n;
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - last_print_).count() >= min_interval_s_) {
    last_print_ = now;
    DYPHO_LOG(Info) << Line(extra);
  }
}

void Progress::Finish(const std::string& extra) {
  if (finished_) return;
  finished_ = true;
  DYPHO_LOG(Info) << Line(extra);
}

}  // namespace dypho
