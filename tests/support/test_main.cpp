// Test entry point: library warnings fail the test that emits them unless it expects them
// (ExpectWarnings in test_support.h).
#include <gtest/gtest.h>

#include "support/test_support.h"

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  shatter::test::install_warning_guard();
  return RUN_ALL_TESTS();
}
