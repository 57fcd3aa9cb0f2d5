#include <gtest/gtest.h>

#include "common/logging.h"

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  dypho::SetLogLevel(dypho::LogLevel::kWarning);
  return RUN_ALL_TESTS();
}
