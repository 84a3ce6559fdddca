#include "geometry/points_near_model.h"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace aqs {
namespace {

// The unit cube's corners: bounding-box centre (0.5, 0.5, 0.5), size sqrt(3).
Eigen::Matrix3Xd UnitCubeCorners() {
  Eigen::Matrix3Xd corners(3, 8);
  for (int i = 0; i < 8; ++i) corners.col(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  return corners;
}

TEST(PointsNearModelTest, ModelSizeIsTheBoundingBoxDiagonal) {
  EXPECT_DOUBLE_EQ(ModelSize(UnitCubeCorners()), std::sqrt(3.0));
  Eigen::Matrix3Xd moved = 2.0 * UnitCubeCorners();
  moved.row(1).array() += 5.0;
  EXPECT_DOUBLE_EQ(ModelSize(moved), 2.0 * std::sqrt(3.0));
  EXPECT_EQ(ModelSize(Eigen::Matrix3Xd(3, 0)), 0.0);
  EXPECT_EQ(ModelSize(Eigen::Matrix3Xd::Ones(3, 1)), 0.0);
}

TEST(PointsNearModelTest, AcceptsPointsWithinTheLimitAndNamesTheFirstBeyondIt) {
  const Eigen::Matrix3Xd neutral = UnitCubeCorners();
  const double limit = kMaxDistanceInModelSizes * std::sqrt(3.0);
  Eigen::Matrix3Xd points = Eigen::Matrix3Xd::Constant(3, 3, 0.5);
  points(0, 1) = 0.5 + 0.999 * limit;
  std::string error;
  EXPECT_TRUE(CheckPointsNearModel("scan.ply", neutral, points, &error)) << error;

  points(0, 2) = 0.5 + 1.001 * limit;
  EXPECT_FALSE(CheckPointsNearModel("scan.ply", neutral, points, &error));
  EXPECT_EQ(error.rfind("scan.ply: point 2 (", 0), 0u) << error;
  EXPECT_NE(error.find("another frame or unit"), std::string::npos) << error;
}

TEST(PointsNearModelTest, RefusesNonFinitePoints) {
  const Eigen::Matrix3Xd neutral = UnitCubeCorners();
  Eigen::Matrix3Xd points = Eigen::Matrix3Xd::Zero(3, 2);
  std::string error;
  points(2, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(CheckPointsNearModel("pose.obj", neutral, points, &error));
  EXPECT_EQ(error.rfind("pose.obj: point 1 (", 0), 0u) << error;
  points(2, 1) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(CheckPointsNearModel("pose.obj", neutral, points, &error));
  points(2, 1) = 1e154;  // its squared norm overflows; the check must not pass it
  EXPECT_FALSE(CheckPointsNearModel("pose.obj", neutral, points, &error));
}

TEST(PointsNearModelTest, AnEmptyNeutralChecksNothing) {
  std::string error;
  EXPECT_TRUE(CheckPointsNearModel("pose.obj", Eigen::Matrix3Xd(3, 0),
                                   Eigen::Matrix3Xd::Constant(3, 1, 1e30), &error));
}

TEST(PointsNearModelTest, TargetOffsetIsTheMedianDistanceToTheVertices) {
  const Eigen::Matrix3Xd neutral = UnitCubeCorners();
  const double size = std::sqrt(3.0);
  std::vector<int> vertices = {0, 1, 2, 3, 4};
  Eigen::Matrix3Xd points(3, 5);
  for (int i = 0; i < 5; ++i) points.col(i) = neutral.col(vertices[i]);
  // Two of five points far off: the median is still 0.
  points(0, 0) += 100.0;
  points(0, 1) += 100.0;
  std::string error;
  EXPECT_TRUE(CheckTargetOffsetFromModel("m.txt", neutral, vertices, points, &error)) << error;
  // Three of five just within and beyond one model size.
  points(1, 2) += 0.99 * size;
  EXPECT_TRUE(CheckTargetOffsetFromModel("m.txt", neutral, vertices, points, &error)) << error;
  points.col(2) = neutral.col(2) + Eigen::Vector3d(0, 1.01 * size, 0);
  points.col(3) = neutral.col(3) + Eigen::Vector3d(0, 0, 2 * size);
  EXPECT_FALSE(CheckTargetOffsetFromModel("m.txt", neutral, vertices, points, &error));
  EXPECT_EQ(error.rfind("m.txt: its points lie a median ", 0), 0u) << error;
  EXPECT_NE(error.find("another unit"), std::string::npos) << error;
  // Without vertices (a scan): the nearest vertex counts. The cube scaled by 10 about
  // its corner 0 is off by a median of several sizes.
  EXPECT_TRUE(CheckTargetOffsetFromModel("s.ply", neutral, {}, neutral, &error)) << error;
  EXPECT_FALSE(CheckTargetOffsetFromModel("s.ply", neutral, {}, 10.0 * neutral, &error));
  EXPECT_NE(error.find("from the model's nearest vertices"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
