#include "util/machine_info.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace aqs {
namespace {

TEST(MachineInfoTest, DescribesHostCoresAndProcessor) {
  const std::string text = MachineDescription();
  const size_t colon = text.find(": ");
  ASSERT_NE(colon, std::string::npos) << text;
  EXPECT_GT(colon, 0u) << text;  // a host name
  const size_t cores = text.find(" cores, ", colon);
  ASSERT_NE(cores, std::string::npos) << text;
  EXPECT_GE(std::stoi(text.substr(colon + 2, cores - colon - 2)), 1) << text;
  EXPECT_GT(text.size(), cores + 8) << text;  // a processor name, or "unknown processor"
}

TEST(MachineInfoTest, LoadAverageHasThreeNumbers) {
  if (!std::filesystem::exists("/proc/loadavg")) GTEST_SKIP() << "no /proc/loadavg";
  const std::string text = LoadAverage();
  double one = -1, five = -1, fifteen = -1;
  ASSERT_EQ(std::sscanf(text.c_str(), "%lf %lf %lf", &one, &five, &fifteen), 3) << text;
  EXPECT_GE(one, 0.0);
  EXPECT_GE(five, 0.0);
  EXPECT_GE(fifteen, 0.0);
}

TEST(MachineInfoTest, BenchmarkLineHasMachineLoadAndUtcDate) {
  const std::string line = BenchmarkMachineLine();
  EXPECT_EQ(line.rfind("machine " + MachineDescription() + "; load average ", 0), 0u) << line;
  ASSERT_GT(line.size(), 21u);
  const std::string date = line.substr(line.size() - 20);  // "YYYY-MM-DD HH:MM UTC"
  int year = 0, month = 0, day = 0, hour = -1, minute = -1;
  ASSERT_EQ(std::sscanf(date.c_str(), "%4d-%2d-%2d %2d:%2d UTC", &year, &month, &day, &hour,
                        &minute),
            5)
      << line;
  EXPECT_GE(year, 2024);
  EXPECT_TRUE(month >= 1 && month <= 12 && day >= 1 && day <= 31) << line;
  EXPECT_TRUE(hour >= 0 && hour < 24 && minute >= 0 && minute < 60) << line;
  EXPECT_EQ(line.find('\n'), std::string::npos) << line;
}

TEST(MachineInfoTest, ProcessorTimeGrowsWithWork) {
  const double before = ProcessCpuSeconds();
  volatile double sum = 0.0;
  for (int i = 0; i < 20000000; ++i) sum = sum + std::sqrt(static_cast<double>(i));
  const double after = ProcessCpuSeconds();
  EXPECT_GT(before, 0.0);
  EXPECT_GT(after, before);
}

}  // namespace
}  // namespace aqs
