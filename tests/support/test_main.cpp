// Test entry point: floating-point traps on, so a NaN or an overflow fails the test where it arises
// (issue 9). A test that injects a fault on purpose turns them off with ScopedFpTrapsOff.
#include <gtest/gtest.h>

#include "support/fp_traps.h"

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  pliant::testing::enable_fp_traps();
  return RUN_ALL_TESTS();
}
