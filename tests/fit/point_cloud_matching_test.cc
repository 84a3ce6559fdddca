// MatchPointCloud (fit/point_cloud_matching.h): closest points of a scan on a surface,
// with robust weights and the matched triangles' normals; CloudDataTerm, the scan fit's
// data term; RobustDistance and its slope.

#include "fit/point_cloud_matching.h"

#include <cmath>
#include <string>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "testing/finite_difference.h"

namespace aqs {
namespace {

// The unit square in the plane z = 0 as two triangles, and four scan points above and
// below it at heights 0.1, -0.5, 2 and 0 (on an edge).
class PointCloudMatchingTest : public ::testing::Test {
 protected:
  PointCloudMatchingTest() : surface_(3, 4), triangles_(3, 2), points_(3, 4) {
    surface_ << 0, 1, 1, 0,  //
        0, 0, 1, 1,          //
        0, 0, 0, 0;
    triangles_ << 0, 0,  //
        1, 2,            //
        2, 3;
    points_ << 0.25, 0.75, 0.5, 0.5,  //
        0.5, 0.25, 0.5, 0.5,          //
        0.1, -0.5, 2.0, 0.0;
  }
  Eigen::Matrix3Xd surface_;
  Eigen::Matrix3Xi triangles_;
  Eigen::Matrix3Xd points_;
};

TEST_F(PointCloudMatchingTest, WeightsAreCauchyAndZeroBeyondTheCap) {
  PointCloudFitOptions options;
  options.max_distance = 1.0;
  options.robust_scale = 0.2;
  options.tangential_weight = 1.0;  // point-to-point: no normals
  int used = 0;
  double mean = 0;
  const FitTarget target =
      MatchPointCloud(points_, surface_, triangles_, options, 1, &used, &mean);
  ASSERT_EQ(target.num_points(), 4);
  EXPECT_EQ(target.positions, points_);
  EXPECT_EQ(target.normals.cols(), 0);
  const double distances[] = {0.1, 0.5, 2.0, 0.0};
  for (int i = 0; i < 4; ++i) {
    const double r = distances[i] / 0.2;
    const double expected = distances[i] > 1.0 ? 0.0 : 1.0 / (1.0 + r * r);
    EXPECT_NEAR(target.weights[i], expected, 1e-12) << "point " << i;
    // The matched point is the point's projection onto the plane.
    Eigen::Vector3d on_surface = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j) {
      on_surface += target.barycentric(j, i) * surface_.col(target.vertices(j, i));
    }
    EXPECT_NEAR((on_surface - Eigen::Vector3d(points_(0, i), points_(1, i), 0)).norm(), 0,
                1e-12)
        << "point " << i;
  }
  EXPECT_EQ(used, 3);  // the point 2 away is beyond max_distance
  EXPECT_NEAR(mean, (0.1 + 0.5 + 0.0) / 3, 1e-12);
}

TEST_F(PointCloudMatchingTest, PlainLeastSquaresAndNormals) {
  PointCloudFitOptions options;
  options.max_distance = 0.0;  // no cap
  options.robust_scale = 0.0;  // no robust weights
  options.tangential_weight = 0.2;
  int used = 0;
  double mean = 0;
  const FitTarget target =
      MatchPointCloud(points_, surface_, triangles_, options, 1, &used, &mean);
  EXPECT_EQ(target.weights, Eigen::VectorXd::Ones(4));
  EXPECT_EQ(used, 4);
  EXPECT_NEAR(mean, (0.1 + 0.5 + 2.0 + 0.0) / 4, 1e-12);
  EXPECT_EQ(target.tangential_weight, 0.2);
  ASSERT_EQ(target.normals.cols(), 4);
  for (int i = 0; i < 4; ++i) {
    // Both triangles are counter-clockwise seen from +z.
    EXPECT_NEAR((target.normals.col(i) - Eigen::Vector3d(0, 0, 1)).norm(), 0, 1e-12);
  }
}

TEST_F(PointCloudMatchingTest, CloudDataTermIsTheMeanRobustSquaredDistanceCapped) {
  PointCloudFitOptions options;
  options.max_distance = 1.0;
  options.robust_scale = 0.2;
  int within = 0;
  const double term = CloudDataTerm(points_, surface_, triangles_, options, 1, &within);
  auto robust = [](double d) { return d * d / (1.0 + (d / 0.2) * (d / 0.2)); };
  // The point 2 away counts at the cap.
  EXPECT_NEAR(term, (robust(0.1) + robust(0.5) + robust(1.0) + 0.0) / 4, 1e-12);
  EXPECT_EQ(within, 3);
  options.max_distance = 0.0;
  options.robust_scale = 0.0;
  EXPECT_NEAR(CloudDataTerm(points_, surface_, triangles_, options, 1, &within),
              (0.01 + 0.25 + 4.0) / 4, 1e-12);
  EXPECT_EQ(within, 4);
}

TEST(RobustDistanceTest, SlopeMatchesCentralDifferences) {
  // Across the Cauchy knee (|d| = s), far beyond it, at 0 and on both sides; for s <= 0
  // (plain least squares) R(d) = d and the slope is 1.
  for (const double s : {0.03, 1.0, 0.0, -0.5}) {
    const double unit = s > 0 ? s : 1.0;
    for (const double t : {-5.0, -1.0, -0.3, 0.0, 0.5, 1.0, 5.0}) {
      const double d = t * unit;
      SCOPED_TRACE("s " + std::to_string(s) + ", d " + std::to_string(d));
      double slope = 0;
      const double r = RobustDistance(d, s, &slope);
      EXPECT_EQ(RobustDistance(d, s, nullptr), r);
      if (s <= 0) {
        EXPECT_EQ(r, d);
        EXPECT_EQ(slope, 1.0);
      }
      auto robust = [s](const Eigen::VectorXd& x) { return RobustDistance(x[0], s, nullptr); };
      const double differenced = testing::CentralDifferenceGradient(
          robust, Eigen::VectorXd::Constant(1, d), 1e-3 * unit)[0];
      // Measured: at most 1.5e-12 (slopes are at most 1).
      EXPECT_NEAR(slope, differenced, 1.5e-10);
    }
  }
}

}  // namespace
}  // namespace aqs
