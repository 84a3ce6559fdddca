#include "eval/scan_error_split.h"

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace aqs {
namespace {

// A regular grid of points in the plane z = 0: columns i + n j at (i h, j h, 0).
Eigen::Matrix3Xd PlaneGrid(int n, double h) {
  Eigen::Matrix3Xd points(3, n * n);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) points.col(i + n * j) << i * h, j * h, 0.0;
  }
  return points;
}

TEST(ScanErrorSplitTest, MedianSpacingOfAGridIsItsStep) {
  EXPECT_NEAR(MedianPointSpacing(PlaneGrid(30, 0.25)), 0.25, 1e-12);
  // Shuffled, rotated and moved: the same spacing.
  Eigen::Matrix3Xd points = PlaneGrid(30, 0.25);
  std::mt19937 random(3);
  for (Eigen::Index i = points.cols() - 1; i > 0; --i) {
    points.col(i).swap(points.col(std::uniform_int_distribution<Eigen::Index>(0, i)(random)));
  }
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  points = (rotation * points).colwise() + Eigen::Vector3d(5, -2, 1);
  EXPECT_NEAR(MedianPointSpacing(points), 0.25, 1e-12);
  // Two points: their distance.
  Eigen::Matrix3Xd two(3, 2);
  two << 0, 1, 0, 0, 0, 0;
  EXPECT_NEAR(MedianPointSpacing(two), 1.0, 1e-12);
}

// Copies of points (a triangle soup's vertices, a scan written twice) count once: before
// 2026-12-07 a cloud whose points all had a copy had spacing 0, and no vertex was in the
// region it sees. All copies of one point: spacing 0, no region.
TEST(ScanErrorSplitTest, CopiesOfPointsCountOnce) {
  const Eigen::Matrix3Xd grid = PlaneGrid(20, 0.25);
  Eigen::Matrix3Xd twice(3, 2 * grid.cols());
  twice << grid, grid;
  EXPECT_NEAR(MedianPointSpacing(twice), 0.25, 1e-12);
  std::vector<int> all(grid.cols());
  for (int v = 0; v < static_cast<int>(grid.cols()); ++v) all[v] = v;
  EXPECT_EQ(ScannedVertices(grid, all, twice).size(), grid.cols());
  const Eigen::Matrix3Xd one_point = Eigen::Matrix3Xd::Constant(3, 5, 0.5);
  EXPECT_EQ(MedianPointSpacing(one_point), 0.0);
  EXPECT_TRUE(ScannedVertices(grid, all, one_point).empty());
}

// A few stray points far from the scan change neither its spacing nor the grid's cells
// (which are sized from the bulk of the points: with the bounding box, one point 1e4 away
// put 80,000 points into a few cells, and the search took 200 times as long).
TEST(ScanErrorSplitTest, StrayPointsLeaveTheSpacingAlone) {
  Eigen::Matrix3Xd points(3, 250 * 250 + 3);
  points << PlaneGrid(250, 0.1), Eigen::Vector3d(1e4, 1e4, 1e4), Eigen::Vector3d(-3e3, 0, 7),
      Eigen::Vector3d(0, 0, 1e5);
  EXPECT_NEAR(MedianPointSpacing(points), 0.1, 1e-12);
}

// Brute force against the grid, on random points and random radii.
TEST(ScanErrorSplitTest, VerticesNearCloudMatchesBruteForce) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::Matrix3Xd vertices(3, 300), cloud(3, 200);
  for (Eigen::Index i = 0; i < vertices.size(); ++i) vertices.data()[i] = 2 * uniform(random);
  for (Eigen::Index i = 0; i < cloud.size(); ++i) cloud.data()[i] = uniform(random);
  std::vector<int> candidates;
  for (int v = 0; v < 300; v += 2) candidates.push_back(v);
  for (double radius : {0.15, 0.3, 0.6}) {
    std::vector<int> expected;
    for (int v : candidates) {
      if (((cloud.colwise() - vertices.col(v)).colwise().norm().array() <= radius).any()) {
        expected.push_back(v);
      }
    }
    EXPECT_EQ(VerticesNearCloud(vertices, candidates, cloud, radius), expected) << radius;
    EXPECT_FALSE(expected.empty());
  }
  EXPECT_TRUE(VerticesNearCloud(vertices, candidates, Eigen::Matrix3Xd(3, 0), 0.5).empty());
}

// On a plane with normals +z: a sideways slide is tangential error only, a lift normal
// only, and both add up as vectors; only the given vertices count.
TEST(ScanErrorSplitTest, SplitsAlongTheTruthsNormals) {
  const Eigen::Matrix3Xd truth = PlaneGrid(4, 1.0);
  Eigen::Matrix3Xd normals = Eigen::Matrix3Xd::Zero(3, truth.cols());
  normals.row(2).setOnes();
  Eigen::Matrix3Xd surface = truth;
  surface.row(0).array() += 0.3;  // a slide along the surface
  const std::vector<int> all = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
  NormalTangentialError split = SplitError(surface, truth, normals, all);
  EXPECT_NEAR(split.normal, 0.0, 1e-15);
  EXPECT_NEAR(split.tangential, 0.3, 1e-15);
  EXPECT_NEAR(split.total, 0.3, 1e-15);
  surface.row(2).array() -= 0.4;  // and a drop through it
  split = SplitError(surface, truth, normals, all);
  EXPECT_NEAR(split.normal, 0.4, 1e-15);
  EXPECT_NEAR(split.tangential, 0.3, 1e-15);
  EXPECT_NEAR(split.total, 0.5, 1e-15);
  surface.col(5) += Eigen::Vector3d(0, 0, 10);  // vertex 5 is not measured
  split = SplitError(surface, truth, normals, {0, 1, 2, 3, 4});
  EXPECT_NEAR(split.normal, 0.4, 1e-15);
  EXPECT_EQ(SplitError(surface, truth, normals, {}).total, 0.0);
}

}  // namespace
}  // namespace aqs
