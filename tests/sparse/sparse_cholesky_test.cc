#include "sparse/sparse_cholesky.h"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <random>
#include <sstream>
#include <utility>

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include "physics/boundary_conditions.h"
#include "physics/stiffness_assembly.h"
#include "testing/fault_kill.h"
#include "testing/finite_difference.h"
#include "testing/test_meshes.h"

#if defined(__SANITIZE_ADDRESS__)
// Under AddressSanitizer (AQS_SANITIZE) a failed allocation returns null, as glibc's
// does, for SparseCholeskyMemoryTest: by default the sanitizer reports it and aborts, and
// that report, itself short of memory under the test's address-space limit, deadlocks.
extern "C" const char* __asan_default_options() { return "allocator_may_return_null=1"; }
#endif

namespace aqs {
namespace {

class SparseCholeskyTest : public ::testing::Test {
 protected:
  SparseCholeskyTest()
      : mesh_(testing::BarMesh(4, 2, 2, 0.5)),
        model_(mesh_, 1.0),
        pattern_(mesh_.tets,
                 FixedVertexMask(testing::LeftFaceFixed(mesh_), mesh_.num_vertices())) {
    AssembleStiffness(model_, pattern_, mesh_.vertices, IdentityActuations(mesh_.num_tets()),
                      StiffnessKind::kExact, 2, &values_);
  }
  TetMesh mesh_;
  ShapeTargetModel model_;
  StiffnessPattern pattern_;
  std::vector<double> values_;
};

TEST_F(SparseCholeskyTest, SolvesLikeDenseCholeskyAndReusesAnalysis) {
  SparseCholesky cholesky(pattern_.num_dofs(), &pattern_.column_starts(), &pattern_.row_indices());
  std::string error;
  ASSERT_TRUE(cholesky.Factorize(values_, &error)) << error;
  EXPECT_GT(cholesky.factor_nonzeros(), 0);
  const Eigen::MatrixXd dense = DenseFromUpperCsc(pattern_, values_);
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd b(pattern_.num_dofs(), 3);
  for (int i = 0; i < b.size(); ++i) b.data()[i] = normal(rng);
  const Eigen::MatrixXd x = cholesky.Solve(b);
  EXPECT_LT(testing::RelativeError(dense * x, b), 1e-10);
  EXPECT_LT(testing::RelativeError(x, dense.llt().solve(b)), 1e-9);
  // New values, same pattern: refactorize without a new analysis.
  std::vector<double> scaled = values_;
  for (double& v : scaled) v *= 3.0;
  ASSERT_TRUE(cholesky.Factorize(scaled, &error)) << error;
  EXPECT_LT(testing::RelativeError(cholesky.Solve(b), x / 3.0), 1e-10);
}

// The factor's storage, known from the analysis: at least its non-zeros as doubles (a
// supernodal factor also stores the zeros inside its supernodes), at most a dense
// triangle with its indices.
TEST_F(SparseCholeskyTest, FactorBytesBoundTheFactorsStorage) {
  SparseCholesky cholesky(pattern_.num_dofs(), &pattern_.column_starts(), &pattern_.row_indices());
  EXPECT_EQ(cholesky.factor_bytes(), 0.0);
  cholesky.Analyze();
  const double n = pattern_.num_dofs();
  EXPECT_GE(cholesky.factor_bytes(), 8.0 * cholesky.factor_nonzeros());
  EXPECT_LE(cholesky.factor_bytes(), 16.0 * n * (n + 1) / 2 + 64.0 * n);
}

// A symbolic analysis that runs out of memory (the child process's address space capped
// just above what it holds) fails with a message instead of aborting the process, and so
// does the factorization that needs it.
TEST(SparseCholeskyMemoryTest, AnalysisOutOfMemoryIsAnError) {
  // The upper triangle of a 7-point grid Laplacian on 60^3 nodes.
  const int k = 60, n = k * k * k;
  std::vector<int64_t> column_starts(n + 1, 0), row_indices;
  row_indices.reserve(4 * static_cast<size_t>(n));
  for (int c = 0; c < n; ++c) {
    column_starts[c] = static_cast<int64_t>(row_indices.size());
    for (int step : {k * k, k, 1}) {
      if (c - step >= 0) row_indices.push_back(c - step);
    }
    std::sort(row_indices.begin() + column_starts[c], row_indices.end());
    row_indices.push_back(c);
  }
  column_starts[n] = static_cast<int64_t>(row_indices.size());
  const std::vector<double> values(row_indices.size(), 1.0);
  const std::string outcome = testing::RunInChildKilledAt(-1, [&]() {
    if (!testing::LimitAddressSpaceToCurrentPlus(2 << 20)) return false;
    try {
      SparseCholesky cholesky(n, &column_starts, &row_indices);
      std::string error;
      if (cholesky.Analyze(&error) || error.find("out of memory") == std::string::npos) {
        std::fprintf(stderr, "analysis: '%s'\n", error.c_str());
        return false;
      }
      error.clear();
      return !cholesky.Factorize(values, &error) &&
             error.find("symbolic analysis") != std::string::npos;
    } catch (const std::exception& e) {  // not what is tested: end the child here
      std::fprintf(stderr, "exception: %s\n", e.what());
      return false;
    }
  });
  EXPECT_EQ(outcome, "exit 0");
}

TEST_F(SparseCholeskyTest, ReportsIndefiniteMatrixAndRecovers) {
  SparseCholesky cholesky(pattern_.num_dofs(), &pattern_.column_starts(), &pattern_.row_indices());
  std::vector<double> negated = values_;
  for (double& v : negated) v = -v;
  std::string error;
  EXPECT_FALSE(cholesky.Factorize(negated, &error));
  EXPECT_FALSE(cholesky.factorized());
  EXPECT_GE(cholesky.failed_column(), 0);
  EXPECT_LT(cholesky.failed_column(), pattern_.num_dofs());
  EXPECT_NE(error.find("not positive definite"), std::string::npos) << error;
  // The same object factorizes a good matrix afterwards.
  ASSERT_TRUE(cholesky.Factorize(values_, &error)) << error;
  EXPECT_TRUE(cholesky.factorized());
}

// A non-finite entry (NaN on or off the diagonal, an infinite diagonal) is refused by
// its column: CHOLMOD took a NaN pivot for a positive one, and the solves were NaN.
TEST_F(SparseCholeskyTest, RefusesNonFiniteEntriesByTheirColumn) {
  SparseCholesky cholesky(pattern_.num_dofs(), &pattern_.column_starts(), &pattern_.row_indices());
  const std::vector<int64_t>& starts = pattern_.column_starts();
  const std::vector<int64_t>& rows = pattern_.row_indices();
  const int column = pattern_.num_dofs() / 2;
  // The column's diagonal entry (its last: rows <= column, in order) and its first.
  const int64_t diagonal = starts[column + 1] - 1, first = starts[column];
  ASSERT_EQ(rows[diagonal], column);
  ASSERT_LT(rows[first], column);
  for (const auto& [entry, value] :
       {std::make_pair(diagonal, std::numeric_limits<double>::quiet_NaN()),
        std::make_pair(first, std::numeric_limits<double>::quiet_NaN()),
        std::make_pair(diagonal, std::numeric_limits<double>::infinity())}) {
    std::vector<double> values = values_;
    values[entry] = value;
    std::string error;
    EXPECT_FALSE(cholesky.Factorize(values, &error));
    EXPECT_FALSE(cholesky.factorized());
    EXPECT_EQ(cholesky.failed_column(), column);
    std::ostringstream expected;
    expected << "the matrix has a non-finite entry (" << value << ") at row " << rows[entry]
             << ", column " << column << " of " << pattern_.num_dofs();
    EXPECT_EQ(error, expected.str());
  }
  std::string error;
  ASSERT_TRUE(cholesky.Factorize(values_, &error)) << error;
  EXPECT_EQ(cholesky.failed_column(), -1);
}

// A single-precision copy of a factor, loaded back into an object of the same
// analysis, solves with its matrix to single precision (as a preconditioner would use
// it), whatever that object factorized in between. Loads that cannot be right change
// nothing.
TEST_F(SparseCholeskyTest, StoredFactorLoadsBackAsAnApproximateInverse) {
  SparseCholesky cholesky(pattern_.num_dofs(), &pattern_.column_starts(), &pattern_.row_indices());
  SparseCholesky other(pattern_.num_dofs(), &pattern_.column_starts(), &pattern_.row_indices());
  StoredFactor stored;
  EXPECT_FALSE(cholesky.StoreFactor(&stored)) << "nothing factorized";
  EXPECT_TRUE(stored.empty());
  std::string error;
  ASSERT_TRUE(cholesky.Factorize(values_, &error)) << error;
  ASSERT_TRUE(cholesky.StoreFactor(&stored));
  EXPECT_EQ(stored.bytes(), cholesky.stored_factor_bytes());
  EXPECT_GT(stored.bytes(), 0.0);
  // Half the factor's values: 4 of every 8 bytes of L->x, without the indices.
  EXPECT_LE(stored.bytes(), 0.5 * cholesky.factor_bytes());
  const Eigen::MatrixXd dense = DenseFromUpperCsc(pattern_, values_);
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd b(pattern_.num_dofs(), 2);
  for (int i = 0; i < b.size(); ++i) b.data()[i] = normal(rng);
  const Eigen::MatrixXd exact = dense.llt().solve(b);

  // Another matrix of the same pattern (a random positive diagonal scaling).
  std::vector<double> scaled = values_;
  std::uniform_real_distribution<double> factor(0.5, 2.0);
  Eigen::VectorXd d(pattern_.num_dofs());
  for (int i = 0; i < d.size(); ++i) d[i] = factor(rng);
  const std::vector<int64_t>& starts = pattern_.column_starts();
  const std::vector<int64_t>& rows = pattern_.row_indices();
  for (int c = 0; c < pattern_.num_dofs(); ++c) {
    for (int64_t p = starts[c]; p < starts[c + 1]; ++p) scaled[p] *= d[rows[p]] * d[c];
  }
  ASSERT_TRUE(cholesky.Factorize(scaled, &error)) << error;
  EXPECT_GT(testing::RelativeError(cholesky.Solve(b), exact), 1e-2);
  ASSERT_TRUE(cholesky.LoadFactor(stored));
  EXPECT_TRUE(cholesky.factorized());
  const double loaded_error = testing::RelativeError(cholesky.Solve(b), exact);
  EXPECT_LT(loaded_error, 1e-4);
  EXPECT_GT(loaded_error, 1e-12) << "rounded to single precision";

  // An object of the same pattern has the same analysis, and takes the copy once it has
  // factorized something (its numeric storage exists).
  EXPECT_FALSE(other.LoadFactor(stored));
  EXPECT_FALSE(other.factorized());
  ASSERT_TRUE(other.Factorize(scaled, &error)) << error;
  EXPECT_EQ(other.structure_id(), cholesky.structure_id());
  ASSERT_TRUE(other.LoadFactor(stored));
  EXPECT_LT(testing::RelativeError(other.Solve(b), exact), 1e-4);

  // A copy of another analysis, or an empty one, is refused and nothing changes.
  std::vector<bool> more_fixed = FixedVertexMask(testing::LeftFaceFixed(mesh_), mesh_.num_vertices());
  more_fixed.back() = true;
  StiffnessPattern smaller(mesh_.tets, more_fixed);
  std::vector<double> smaller_values;
  AssembleStiffness(model_, smaller, mesh_.vertices, IdentityActuations(mesh_.num_tets()),
                    StiffnessKind::kExact, 2, &smaller_values);
  b.conservativeResize(smaller.num_dofs(), Eigen::NoChange);
  SparseCholesky coupled(smaller.num_dofs(), &smaller.column_starts(), &smaller.row_indices());
  ASSERT_TRUE(coupled.Factorize(smaller_values, &error)) << error;
  EXPECT_NE(coupled.structure_id(), cholesky.structure_id());
  const Eigen::MatrixXd before = coupled.Solve(b);
  EXPECT_FALSE(coupled.LoadFactor(stored));
  EXPECT_FALSE(coupled.LoadFactor(StoredFactor()));
  EXPECT_EQ((coupled.Solve(b) - before).cwiseAbs().maxCoeff(), 0.0);
}

// A factorization that fails names the matrix's column (not its place in the elimination
// order), and its factor cannot be stored.
TEST_F(SparseCholeskyTest, AFailedFactorizationNamesItsColumnAndIsNotStored) {
  SparseCholesky cholesky(pattern_.num_dofs(), &pattern_.column_starts(), &pattern_.row_indices());
  const int c = pattern_.num_dofs() / 2;
  std::vector<double> bad = values_;
  const int64_t diagonal = pattern_.column_starts()[c + 1] - 1;  // upper triangle, by column
  bad[diagonal] = -1e3 * std::abs(bad[diagonal]);
  std::string error;
  EXPECT_FALSE(cholesky.Factorize(bad, &error));
  const std::vector<int64_t> permutation = cholesky.Permutation();
  ASSERT_NE(std::find(permutation.begin(), permutation.end(), c) - permutation.begin(), c)
      << "column " << c << " is eliminated at its own place: the test tells nothing";
  EXPECT_EQ(cholesky.failed_column(), c) << error;
  StoredFactor stored;
  EXPECT_FALSE(cholesky.StoreFactor(&stored));
  EXPECT_TRUE(stored.empty());
}

}  // namespace
}  // namespace aqs
