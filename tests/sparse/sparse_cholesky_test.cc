#include "sparse/sparse_cholesky.h"

#include <random>

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include "physics/stiffness_assembly.h"
#include "equilibrium/boundary_conditions.h"
#include "testing/finite_difference.h"
#include "testing/test_meshes.h"

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

}  // namespace
}  // namespace aqs
