// Progress lines: the time-left estimate from the rate, capped by a deadline.
#include "common/progress.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>

namespace dypho {
namespace {

double SecondsLeft(const std::string& line) {
  const size_t end = line.find(" s left");
  EXPECT_NE(end, std::string::npos) << line;
  const size_t start = line.rfind(", ", end);
  return std::atof(line.substr(start + 2, end - start - 2).c_str());
}

TEST(Progress, TimeLeftFollowsTheRateAndNeverPassesTheDeadline) {
  Progress p("work", 1000000, 1e9);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  p.Advance(1);
  EXPECT_GT(SecondsLeft(p.Line("")), 1000.0);  // about 50000 s at this rate
  p.SetDeadline(std::chrono::steady_clock::now() + std::chrono::seconds(5));
  const double left = SecondsLeft(p.Line(""));
  EXPECT_LE(left, 5.0);
  EXPECT_GT(left, 4.0);
}

}  // namespace
}  // namespace dypho
