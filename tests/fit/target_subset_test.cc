#include "fit/target_subset.h"

#include <vector>

#include <gtest/gtest.h>

namespace aqs {
namespace {

// Vertex targets at x = 0, 1, ..., n - 1 on a line (vertex i at point i).
FitTarget LineTarget(int n) {
  std::vector<int> vertices(n);
  Eigen::Matrix3Xd positions = Eigen::Matrix3Xd::Zero(3, n);
  for (int i = 0; i < n; ++i) {
    vertices[i] = i;
    positions(0, i) = i;
  }
  return VertexTarget(vertices, positions);
}

TEST(FarthestPointSubsetTest, SpreadsThePointsFromTheFirst) {
  const FitTarget subset = FarthestPointSubset(LineTarget(10), 3);
  ASSERT_EQ(subset.num_points(), 3);
  // 0, then the farthest from it (9), then the farthest from both (4 and 5 tie at 4:
  // the lower index).
  EXPECT_EQ(subset.vertices(0, 0), 0);
  EXPECT_EQ(subset.vertices(0, 1), 9);
  EXPECT_EQ(subset.vertices(0, 2), 4);
  EXPECT_DOUBLE_EQ(subset.positions(0, 1), 9.0);
  EXPECT_DOUBLE_EQ(subset.barycentric(0, 2), 1.0);
  EXPECT_EQ(subset.weights.size(), 0);
  EXPECT_EQ(subset.normals.cols(), 0);
}

TEST(FarthestPointSubsetTest, SkipsPointsOfZeroWeightAndCopiesWeightsAndNormals) {
  FitTarget target = LineTarget(10);
  target.weights = Eigen::VectorXd::Ones(10);
  target.weights[0] = 0.0;
  target.weights[9] = 0.0;
  target.weights[5] = 2.5;
  target.normals = Eigen::Matrix3Xd::Zero(3, 10);
  target.normals.row(1).setOnes();
  target.normals(2, 8) = 7.0;
  target.tangential_weight = 0.3;
  const FitTarget subset = FarthestPointSubset(target, 2);
  ASSERT_EQ(subset.num_points(), 2);
  EXPECT_EQ(subset.vertices(0, 0), 1);  // the first point of positive weight
  EXPECT_EQ(subset.vertices(0, 1), 8);
  ASSERT_EQ(subset.weights.size(), 2);
  EXPECT_DOUBLE_EQ(subset.weights[1], 1.0);
  ASSERT_EQ(subset.normals.cols(), 2);
  EXPECT_DOUBLE_EQ(subset.normals(2, 1), 7.0);
  EXPECT_DOUBLE_EQ(subset.normals(1, 0), 1.0);
  EXPECT_DOUBLE_EQ(subset.tangential_weight, 0.3);
  // Asking for more than there are usable points gives all of them, in order.
  const FitTarget all = FarthestPointSubset(target, 100);
  ASSERT_EQ(all.num_points(), 8);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(all.vertices(0, i), i + 1);
  EXPECT_DOUBLE_EQ(all.weights[4], 2.5);
}

}  // namespace
}  // namespace aqs
