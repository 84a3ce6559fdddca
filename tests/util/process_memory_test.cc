// The process's memory as the benchmarks report it (util/process_memory.h).

#include "util/process_memory.h"

#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

namespace aqs {
namespace {

TEST(ProcessMemoryTest, PeakCoversCurrentAndGrowsWithWhatIsTouched) {
  // Skipped only without /proc: a parse that fails where the file exists is a failure.
  if (!std::filesystem::exists("/proc/self/status")) GTEST_SKIP() << "no /proc/self/status";
  const double before = CurrentResidentBytes();
  ASSERT_GT(before, 0.0);
  std::vector<char> block(64 << 20, 1);  // 64 MB, every page touched
  const double during = CurrentResidentBytes();
  EXPECT_GT(during, before + 32e6);
  EXPECT_GE(PeakResidentBytes(), during);
  EXPECT_EQ(block[12345], 1);
}

}  // namespace
}  // namespace aqs
