// The simulator benchmark on cube lattices as a library call (jobs/lattice_benchmark.h):
// its options, one size's figures, and the table and CSV of a run.

#include "jobs/lattice_benchmark.h"

#include <limits>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "testing/file_contents.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

TEST(LatticeBenchmarkTest, OptionsCheckEverySizeFirst) {
  LatticeBenchmarkOptions options;
  std::string error;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.cubes = {3, 0};
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error, "cubes takes positive integers, got 0");
  options.cubes = {3, 300};
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("max_memory_bytes (8 GB) is below the estimated", 0), 0u) << error;
  options.cubes = {3};
  options.amplitude = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error,
            "amplitude must be in (-1, 1) (is inf): beyond, some fibres' target stretch is not "
            "positive");
  options.amplitude = 1.0;
  EXPECT_FALSE(options.Validate(&error));
  options.amplitude = 0.3;
  options.tolerance = 1e300;  // "converged" before any step
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error, "tolerance must be at most 0.1 (is 1e+300): above, a solve stops where it "
                   "starts");
  options.tolerance = 1e-17;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("tolerance must be >= 1e-13", 0), 0u) << error;
}

TEST(LatticeBenchmarkTest, MeasuresEverySizeAsRatiosToItsUnit) {
  LatticeBenchmarkOptions options;
  std::ostringstream warnings;
  LatticeBenchmarkRow row;
  std::string error;
  ASSERT_TRUE(MeasureLattice(options, 3, warnings, &row, &error)) << error;
  EXPECT_EQ(warnings.str(), "");  // every solve converged
  EXPECT_EQ(row.cubes, 3);
  EXPECT_EQ(row.elements, 6 * 27);
  EXPECT_GT(row.unit, 0.0);
  EXPECT_GT(row.factor_nonzeros, 0.0);
  EXPECT_GT(row.gradient, 0.0);
  EXPECT_GT(row.lm_solve_iterations, 0);
  EXPECT_GT(row.solve_newton, 0);  // the default method ends with Newton's factorizations
  EXPECT_GT(row.svd_ns, 0.0);
  EXPECT_GT(row.svd_reference_ns, 0.0);
  EXPECT_GT(row.dynamic_lm_iteration, 0.0);  // small enough to compare orderings

  testing::TempDir dir;
  options.cubes = {2, 3};
  options.csv = dir.File("lattices.csv");
  std::ostringstream out;
  ASSERT_EQ(RunLatticeBenchmark(options, out, &error), JobStatus::kOk) << error;
  EXPECT_NE(out.str().find("Ratios are to 'unit'"), std::string::npos) << out.str();
  const std::string csv = testing::ReadAll(options.csv);
  EXPECT_EQ(csv.rfind("elements,dofs,factor_nonzeros,", 0), 0u) << csv;
  EXPECT_NE(csv.find("\n48,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\n162,"), std::string::npos) << csv;
}

}  // namespace
}  // namespace aqs
