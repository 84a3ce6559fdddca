// The solver benchmark as a library call (jobs/solve_benchmark.h): its options, a
// lattice case with both methods, and inputs checked before the first solve.

#include "jobs/solve_benchmark.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "testing/file_contents.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

TEST(SolveBenchmarkTest, OptionsNameTheBadField) {
  SolveBenchmarkOptions options;
  std::string error;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.methods = {"newton", "cg"};
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error, "methods: 'cg' is not newton or lm");
  options = SolveBenchmarkOptions();
  options.lattice = {4, 4};
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("lattice must be three positive cube counts", 0), 0u) << error;
  options = SolveBenchmarkOptions();
  options.curl = 1.0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("curl must be in [0, 1)", 0), 0u) << error;
  options = SolveBenchmarkOptions();
  options.attachment_stiffness = 1e9;  // prepare's largest is 1e8
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("attachment_stiffness must be in [0, 1e+08]", 0), 0u) << error;
  options = SolveBenchmarkOptions();
  options.max_memory_bytes = 1e6;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("max_memory_bytes (1 MB) is below the estimated", 0), 0u) << error;
}

TEST(SolveBenchmarkTest, BothMethodsReachTheSameCurl) {
  testing::TempDir dir;
  SolveBenchmarkOptions options;
  options.lattice = {10, 2, 2};
  options.csv = dir.File("solves.csv");
  std::ostringstream out;
  std::string error;
  ASSERT_EQ(RunSolveBenchmark(options, out, &error), JobStatus::kOk) << error;
  EXPECT_NE(out.str().find("lattice_curl               240 newton  yes"), std::string::npos)
      << out.str();
  EXPECT_NE(out.str().find("lattice_curl               240 lm      yes"), std::string::npos)
      << out.str();
  const std::string csv = testing::ReadAll(options.csv);
  EXPECT_EQ(csv.rfind("case,elements,method,converged,", 0), 0u) << csv;
  EXPECT_NE(csv.find("\nlattice_curl,240,newton,1,"), std::string::npos) << csv;
  const size_t lm = csv.find("\nlattice_curl,240,lm,1,");
  ASSERT_NE(lm, std::string::npos) << csv;
  // The benchmark's own agreement figure: the second method's equilibrium is the first's
  // (largest vertex distance over the bounding-box diagonal), not another one.
  const size_t end = csv.find('\n', lm + 1);
  const std::string row = csv.substr(lm + 1, end == std::string::npos ? end : end - lm - 1);
  const double difference = std::stod(row.substr(row.rfind(',') + 1));
  EXPECT_LT(difference, 1e-5) << row;
}

// The end x = 0 is held at any spacing: with an absolute threshold of 1e-9 a lattice that
// fine had every vertex fixed, and each solve "converged" at the start.
TEST(SolveBenchmarkTest, AFineLatticeHoldsOnlyItsEnd) {
  testing::TempDir dir;
  SolveBenchmarkOptions options;
  options.lattice = {10, 2, 2};
  options.spacing = 1e-12;
  options.methods = {"newton"};
  options.csv = dir.File("solves.csv");
  std::ostringstream out;
  std::string error;
  ASSERT_EQ(RunSolveBenchmark(options, out, &error), JobStatus::kOk) << error;
  const std::string csv = testing::ReadAll(options.csv);
  const std::string prefix = "\nlattice_curl,240,newton,1,";
  const size_t row = csv.find(prefix);
  ASSERT_NE(row, std::string::npos) << csv;
  EXPECT_GE(std::stoi(csv.substr(row + prefix.size())), 1) << "factorizations\n" << csv;
}

TEST(SolveBenchmarkTest, AMissingModelIsRefusedBeforeAnySolve) {
  testing::TempDir dir;
  SolveBenchmarkOptions options;
  options.model = dir.File("none");
  options.poses = {"jawOpen"};
  std::ostringstream out;
  std::string error;
  EXPECT_EQ(RunSolveBenchmark(options, out, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("model.txt"), std::string::npos) << error;
  EXPECT_EQ(out.str(), "") << "the lattice case ran first";
}

}  // namespace
}  // namespace aqs
