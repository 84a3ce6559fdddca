#include "fit/fit_target.h"

#include <gtest/gtest.h>

namespace aqs {
namespace {

TEST(FitTargetTest, PointsAndDataTermWithWeightsAndNormals) {
  // Two triangles' corners as the surface; one point inside the first triangle, one on
  // a vertex.
  Eigen::Matrix3Xd surface(3, 4);
  surface << 0, 1, 0, 1,  //
      0, 0, 1, 1,         //
      0, 0, 0, 1;
  FitTarget target = VertexTarget({3}, Eigen::Vector3d(1, 1, 2));
  EXPECT_EQ(target.num_points(), 1);
  EXPECT_EQ(TargetPointsOn(target, surface).col(0), Eigen::Vector3d(1, 1, 1));
  EXPECT_DOUBLE_EQ(TargetDataTerm(target, surface), 1.0);  // |(0, 0, -1)|^2

  target.vertices.resize(3, 2);
  target.vertices << 3, 0, 3, 1, 3, 2;
  target.barycentric.resize(3, 2);
  target.barycentric << 1, 0.5, 0, 0.25, 0, 0.25;
  target.positions.resize(3, 2);
  target.positions << 1, 0.25 + 0.3, 1, 0.25 + 0.4, 2, 0.0 + 0.5;
  const Eigen::Matrix3Xd p = TargetPointsOn(target, surface);
  EXPECT_LT((p.col(1) - Eigen::Vector3d(0.25, 0.25, 0)).norm(), 1e-15);
  // Residuals (0, 0, -1) and (-0.3, -0.4, -0.5); weights 1 and 3.
  target.weights = Eigen::Vector2d(1, 3);
  EXPECT_NEAR(TargetDataTerm(target, surface), (1.0 + 3 * 0.5) / 4, 1e-15);
  EXPECT_DOUBLE_EQ(TotalWeight(target), 4.0);
  EXPECT_DOUBLE_EQ(PriorPoints(target, 2.0), 2.0);
  EXPECT_DOUBLE_EQ(PriorPoints(target, 0.0), 4.0);
  // Point-to-plane: normals z, tangential weight 0.5: the second residual's in-plane
  // part (-0.3, -0.4) counts at a quarter.
  target.normals.resize(3, 2);
  target.normals << 0, 0, 0, 0, 1, 1;
  target.tangential_weight = 0.5;
  EXPECT_NEAR(TargetDataTerm(target, surface), (1.0 + 3 * (0.25 * 0.25 + 0.25)) / 4, 1e-15);
}

}  // namespace
}  // namespace aqs
