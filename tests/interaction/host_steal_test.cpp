// Host steal time as the haptic benchmark reads it: the eighth value of /proc/stat's "cpu " line.
#include <gtest/gtest.h>

#include "interaction/host_steal.h"

namespace pliant {
namespace {

TEST(HostSteal, ReadsTheEighthValueOfTheAggregateCpuLine) {
  // A /proc/stat as Linux 6.1 writes it (two CPUs; the per-CPU lines and the rest must not be read).
  const char* text =
      "cpu  5945792 578427 487898 435734 12334 0 1919 65949 0 0\n"
      "cpu0 2959569 291554 235016 240811 4693 0 107 32658 0 0\n"
      "cpu1 2986222 286873 252881 194923 7641 0 1812 33291 0 0\n"
      "intr 1 2 3\nctxt 42\n";
  EXPECT_EQ(parse_proc_stat_steal_ticks(text), 65949);
  // The aggregate line need not be first, and an old kernel's seven values have no steal.
  EXPECT_EQ(parse_proc_stat_steal_ticks("intr 5\ncpu  1 2 3 4 5 6 7 8\n"), 8);
  EXPECT_EQ(parse_proc_stat_steal_ticks("cpu  1 2 3 4 5 6 7\n"), std::nullopt);
}

TEST(HostSteal, MalformedTextGivesNothing) {
  EXPECT_EQ(parse_proc_stat_steal_ticks(""), std::nullopt);
  EXPECT_EQ(parse_proc_stat_steal_ticks("cpu0 1 2 3 4 5 6 7 8\n"), std::nullopt);  // no aggregate line
  EXPECT_EQ(parse_proc_stat_steal_ticks("cpu  1 2 3 4 x 6 7 8\n"), std::nullopt);
  EXPECT_EQ(parse_proc_stat_steal_ticks("cpu  1 2 3 4 5 6 7 -8\n"), std::nullopt);
  EXPECT_EQ(parse_proc_stat_steal_ticks("cpu  1 2 3 4 5 6 7 8x\n"), std::nullopt);
}

TEST(HostSteal, TheMachinesCounterIsNonNegativeAndNeverFalls) {
  const std::optional<double> first = host_steal_seconds();
  if (!first) GTEST_SKIP() << "/proc/stat has no steal column here";
  const std::optional<double> second = host_steal_seconds();
  ASSERT_TRUE(second.has_value());
  EXPECT_GE(*first, 0.0);
  EXPECT_GE(*second, *first);
}

}  // namespace
}  // namespace pliant
