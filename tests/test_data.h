// Where tests find ../shared/data. In CI the folder must exist: a test that
// needs it fails when it is missing. Elsewhere (a user's checkout) it skips
// with a clear message.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "common/check.h"

namespace dypho::testing {

inline std::string SharedData(const std::string& relative) {
  return std::string(DYPHO_SHARED_DATA) + "/" + relative;
}

inline bool InCi() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::string(ci) != "" && std::string(ci) != "false";
}

// Temporary directory unique to the current test; created fresh.
inline std::string TestTempDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string dir = std::string(DYPHO_BINARY_DIR) + "/test_tmp/" + info->test_suite_name() +
                    "." + info->name();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace dypho::testing

// Skips (outside CI) or fails (in CI) when a ../shared/data entry is missing.
#define DYPHO_REQUIRE_SHARED_DATA(relative)                                              \
  do {                                                                                   \
    const std::string dypho_path_ = ::dypho::testing::SharedData(relative);              \
    if (!std::filesystem::exists(dypho_path_)) {                                         \
      if (::dypho::testing::InCi()) {                                                    \
        FAIL() << "test data missing: " << dypho_path_;                                  \
      } else {                                                                           \
        GTEST_SKIP() << "test data missing (../shared/data is not beside this checkout): " \
                     << dypho_path_;                                                     \
      }                                                                                  \
    }                                                                                    \
  } while (0)

// Expects `statement` to throw dypho::InvalidInput whose message contains `needle`.
#define EXPECT_INVALID_INPUT(statement, needle)                                     \
  do {                                                                              \
    try {                                                                           \
      statement;                                                                    \
      ADD_FAILURE() << "expected InvalidInput containing '" << (needle) << "'";     \
    } catch (const ::dypho::InvalidInput& e) {                                      \
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what(); \
    }                                                                               \
  } while (0)
