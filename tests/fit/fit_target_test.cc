#include "fit/fit_target.h"

#include <cmath>
#include <limits>
#include <string>

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

// A target is data: each problem is named, not aborted on (an empty target, negative
// weights, a vertex of another mesh) or fitted to NaN.
TEST(FitTargetTest, ValidationNamesThePointAndTheProblem) {
  const FitTarget good = VertexTarget({0, 3}, Eigen::Matrix3Xd::Zero(3, 2));
  std::string error;
  EXPECT_TRUE(ValidateFitTarget(good, 4, &error)) << error;
  const auto refused = [&error](const FitTarget& target, const std::string& expected) {
    error.clear();
    EXPECT_FALSE(ValidateFitTarget(target, 4, &error)) << expected;
    EXPECT_EQ(error, "fit target: " + expected);
  };
  refused(FitTarget(), "it has no points");
  refused(VertexTarget({0, 4}, Eigen::Matrix3Xd::Zero(3, 2)),
          "point 1 is on vertex 4, not a surface vertex of the model (0 to 3)");
  refused(VertexTarget({-1}, Eigen::Matrix3Xd::Zero(3, 1)),
          "point 0 is on vertex -1, not a surface vertex of the model (0 to 3)");
  FitTarget nan = good;
  nan.positions(2, 1) = std::nan("");
  refused(nan, "point 1 has a non-finite position");
  FitTarget bary = good;
  bary.barycentric(1, 0) = std::numeric_limits<double>::infinity();
  refused(bary, "point 0 has non-finite barycentric coordinates");
  FitTarget negative = good;
  negative.weights = Eigen::Vector2d(1.0, -1.0);
  refused(negative, "point 1 has the weight -1 (finite and >= 0)");
  FitTarget zero = good;
  zero.weights = Eigen::Vector2d::Zero();
  refused(zero, "its weights sum to 0");
  FitTarget short_weights = good;
  short_weights.weights = Eigen::VectorXd::Ones(1);
  refused(short_weights, "it has 2 points but 1 weights");
  FitTarget normals = good;
  normals.normals = Eigen::Matrix3Xd::Zero(3, 2);
  normals.normals(0, 0) = std::nan("");
  refused(normals, "point 0 has a non-finite normal");
  FitTarget mismatched = good;
  mismatched.vertices.conservativeResize(3, 1);
  refused(mismatched, "it has 2 positions but 1 vertex triples and 2 barycentric triples");
  FitTarget tangential = good;
  tangential.tangential_weight = -0.5;
  refused(tangential, "the tangential weight must be finite and >= 0");
}

}  // namespace
}  // namespace aqs
