#include "geometry/triangle_bvh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "testing/test_surfaces.h"

namespace aqs {
namespace {

// Closest point by dense sampling of the triangle (for checking the exact answer).
double SampledDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                       const Eigen::Vector3d& c, int n) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; i + j <= n; ++j) {
      const double u = static_cast<double>(i) / n, v = static_cast<double>(j) / n;
      best = std::min(best, (p - ((1 - u - v) * a + u * b + v * c)).norm());
    }
  }
  return best;
}

void ExpectConsistent(const Eigen::Vector3d& closest, const Eigen::Vector3d& weights,
                      const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      const Eigen::Vector3d& c) {
  EXPECT_GE(weights.minCoeff(), -1e-12);
  EXPECT_NEAR(weights.sum(), 1.0, 1e-12);
  EXPECT_LT((weights(0) * a + weights(1) * b + weights(2) * c - closest).norm(), 1e-12);
}

TEST(ClosestPointOnTriangleTest, EveryRegion) {
  const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
  struct Case {
    Eigen::Vector3d p;
    Eigen::Vector3d expected;
  };
  const Case cases[] = {
      {{0.5, 0.5, 3}, {0.5, 0.5, 0}},      // face
      {{-1, -1, 1}, {0, 0, 0}},            // vertex a
      {{3, -1, -2}, {2, 0, 0}},            // vertex b
      {{-0.5, 4, 0}, {0, 2, 0}},           // vertex c
      {{1, -3, 1}, {1, 0, 0}},             // edge ab
      {{-2, 1, 0}, {0, 1, 0}},             // edge ca
      {{2, 2, 5}, {1, 1, 0}},              // edge bc
      {{0.25, 0.25, 0}, {0.25, 0.25, 0}},  // on the face
  };
  for (const Case& test : cases) {
    Eigen::Vector3d weights;
    const Eigen::Vector3d closest = ClosestPointOnTriangle(test.p, a, b, c, &weights);
    EXPECT_LT((closest - test.expected).norm(), 1e-14) << test.p.transpose();
    ExpectConsistent(closest, weights, a, b, c);
  }
}

TEST(ClosestPointOnTriangleTest, RandomTrianglesMatchSampling) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1, 1);
  auto random_point = [&]() { return Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)); };
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d a = random_point(), b = random_point(), c = random_point();
    const Eigen::Vector3d p = 2 * random_point();
    Eigen::Vector3d weights;
    const Eigen::Vector3d closest = ClosestPointOnTriangle(p, a, b, c, &weights);
    ExpectConsistent(closest, weights, a, b, c);
    const double sampled = SampledDistance(p, a, b, c, 200);
    // The exact answer is never worse than a sample, and samples come within the grid size.
    EXPECT_LE((p - closest).norm(), sampled + 1e-12);
    EXPECT_GE((p - closest).norm(), sampled - 2e-2);
  }
}

TEST(ClosestPointOnTriangleTest, DegenerateTriangles) {
  const Eigen::Vector3d p(1, 1, 0);
  Eigen::Vector3d weights;
  // Collinear corners: the union of the edges is the segment from (0,0,0) to (3,0,0).
  const Eigen::Vector3d a(0, 0, 0), b(3, 0, 0), c(1.5, 0, 0);
  Eigen::Vector3d closest = ClosestPointOnTriangle(p, a, b, c, &weights);
  EXPECT_LT((closest - Eigen::Vector3d(1, 0, 0)).norm(), 1e-14);
  ExpectConsistent(closest, weights, a, b, c);
  closest = ClosestPointOnTriangle(Eigen::Vector3d(5, 1, 0), c, a, b, &weights);
  EXPECT_LT((closest - b).norm(), 1e-14);
  ExpectConsistent(closest, weights, c, a, b);
  // Two coincident corners: a segment.
  closest = ClosestPointOnTriangle(p, a, a, b, &weights);
  EXPECT_LT((closest - Eigen::Vector3d(1, 0, 0)).norm(), 1e-14);
  ExpectConsistent(closest, weights, a, a, b);
  // All three coincident: a point.
  closest = ClosestPointOnTriangle(p, b, b, b, &weights);
  EXPECT_LT((closest - b).norm(), 1e-14);
  EXPECT_NEAR(weights.sum(), 1.0, 1e-15);
  // Nearly collinear (a sliver 1e-12 thick): still within round-off of the exact answer.
  const Eigen::Vector3d sliver(1.5, 1e-12, 0);
  closest = ClosestPointOnTriangle(p, a, b, sliver, &weights);
  EXPECT_NEAR((p - closest).norm(), 1.0 - 1e-12, 1e-10);
  EXPECT_TRUE(closest.allFinite());
  ExpectConsistent(closest, weights, a, b, sliver);
}

// Brute force over all triangles.
ClosestPointResult BruteForce(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                              const Eigen::Vector3d& p) {
  ClosestPointResult best;
  for (int t = 0; t < triangles.cols(); ++t) {
    Eigen::Vector3d weights;
    const Eigen::Vector3d closest =
        ClosestPointOnTriangle(p, vertices.col(triangles(0, t)), vertices.col(triangles(1, t)),
                               vertices.col(triangles(2, t)), &weights);
    const double distance = (closest - p).norm();
    if (distance < best.distance) {
      best.distance = distance;
      best.triangle = t;
      best.point = closest;
      best.barycentric = weights;
    }
  }
  return best;
}

TEST(TriangleBvhTest, MatchesBruteForceOnSphereAndSoup) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-1, 1);
  // A sphere, and a soup of random triangles with some degenerate ones.
  const SurfaceMesh sphere = testing::Icosphere(3, 1.0);
  Eigen::Matrix3Xd soup_vertices(3, 600);
  for (int v = 0; v < 600; ++v) soup_vertices.col(v) << uniform(rng), uniform(rng), uniform(rng);
  Eigen::Matrix3Xi soup_triangles(3, 200);
  for (int t = 0; t < 200; ++t) soup_triangles.col(t) << 3 * t, 3 * t + 1, 3 * t + 2;
  for (int t = 0; t < 200; t += 10) soup_triangles(2, t) = soup_triangles(1, t);  // degenerate
  for (const auto& [vertices, triangles] : {std::make_pair(sphere.vertices, sphere.triangles),
                                            std::make_pair(soup_vertices, soup_triangles)}) {
    const TriangleBvh bvh(vertices, triangles);
    EXPECT_EQ(bvh.num_triangles(), triangles.cols());
    Eigen::Matrix3Xd points(3, 300);
    for (int i = 0; i < 300; ++i)
      points.col(i) << 1.5 * uniform(rng), 1.5 * uniform(rng), 1.5 * uniform(rng);
    const std::vector<ClosestPointResult> batch = bvh.ClosestPoints(points, 2);
    const std::vector<ClosestPointResult> serial = bvh.ClosestPoints(points, 1);
    for (int i = 0; i < 300; ++i) {
      const ClosestPointResult expected = BruteForce(vertices, triangles, points.col(i));
      const ClosestPointResult& result = batch[i];
      EXPECT_NEAR(result.distance, expected.distance, 1e-14) << "point " << i;
      ASSERT_GE(result.triangle, 0);
      const Eigen::Vector3d reconstructed =
          result.barycentric(0) * vertices.col(triangles(0, result.triangle)) +
          result.barycentric(1) * vertices.col(triangles(1, result.triangle)) +
          result.barycentric(2) * vertices.col(triangles(2, result.triangle));
      EXPECT_LT((reconstructed - result.point).norm(), 1e-12);
      EXPECT_NEAR((result.point - points.col(i)).norm(), result.distance, 1e-14);
      EXPECT_EQ(serial[i].triangle, result.triangle);
      EXPECT_EQ(serial[i].distance, result.distance);
    }
  }
}

TEST(TriangleBvhTest, TrianglesWithinMatchBruteForce) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(-1, 1);
  const SurfaceMesh sphere = testing::Icosphere(3, 1.0);
  const TriangleBvh bvh(sphere.vertices, sphere.triangles);
  std::vector<int> found;
  int total = 0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(1.3 * uniform(rng), 1.3 * uniform(rng), 1.3 * uniform(rng));
    const double radius = 0.02 + 0.3 * (0.5 + 0.5 * uniform(rng));
    std::vector<int> expected;
    for (int t = 0; t < sphere.triangles.cols(); ++t) {
      const Eigen::Vector3d q = ClosestPointOnTriangle(
          p, sphere.vertices.col(sphere.triangles(0, t)),
          sphere.vertices.col(sphere.triangles(1, t)),
          sphere.vertices.col(sphere.triangles(2, t)), nullptr);
      if ((q - p).norm() < radius) expected.push_back(t);
    }
    bvh.TrianglesWithin(p, radius, &found);
    EXPECT_EQ(found, expected) << "point " << i;
    total += static_cast<int>(found.size());
    // Just below the closest distance nothing is within; just above, the closest is.
    const ClosestPointResult closest = bvh.ClosestPoint(p);
    bvh.TrianglesWithin(p, closest.distance * (1.0 - 1e-12), &found);
    EXPECT_TRUE(found.empty());
    bvh.TrianglesWithin(p, closest.distance * (1.0 + 1e-12), &found);
    EXPECT_EQ(std::count(found.begin(), found.end(), closest.triangle), 1);
  }
  EXPECT_GT(total, 200);  // the radii reach several triangles on average
  bvh.TrianglesWithin(Eigen::Vector3d(0, 0, 3), 0.0, &found);
  EXPECT_TRUE(found.empty());
  bvh.TrianglesWithin(Eigen::Vector3d(0, 0, 3), 10.0, &found);
  EXPECT_EQ(found.size(), static_cast<size_t>(sphere.triangles.cols()));
  const TriangleBvh empty(Eigen::Matrix3Xd(3, 0), Eigen::Matrix3Xi(3, 0));
  empty.TrianglesWithin(Eigen::Vector3d::Zero(), 1.0, &found);
  EXPECT_TRUE(found.empty());
}

TEST(TriangleBvhTest, SearchRadiusAndEmptySurface) {
  const SurfaceMesh sphere = testing::Icosphere(2, 1.0);
  const TriangleBvh bvh(sphere.vertices, sphere.triangles);
  const Eigen::Vector3d p(0, 0, 3);
  const ClosestPointResult unlimited = bvh.ClosestPoint(p);
  // The icosphere has a vertex at (0, 0, 1).
  EXPECT_NEAR(unlimited.distance, 2.0, 1e-12);
  EXPECT_LT((unlimited.point - Eigen::Vector3d(0, 0, 1)).norm(), 1e-12);
  const ClosestPointResult near = bvh.ClosestPoint(p, 1.9);
  EXPECT_EQ(near.triangle, -1);
  EXPECT_TRUE(std::isinf(near.distance));
  const ClosestPointResult within = bvh.ClosestPoint(p, 2.1);
  EXPECT_EQ(within.triangle, unlimited.triangle);
  EXPECT_EQ(within.distance, unlimited.distance);
  // Centre: every vertex is at distance 1, faces closer.
  EXPECT_LT(bvh.ClosestPoint(Eigen::Vector3d::Zero()).distance, 1.0);

  const TriangleBvh empty(Eigen::Matrix3Xd(3, 0), Eigen::Matrix3Xi(3, 0));
  EXPECT_EQ(empty.ClosestPoint(p).triangle, -1);
  EXPECT_EQ(empty.ClosestPoints(Eigen::Matrix3Xd::Zero(3, 5), 2).size(), 5u);
}

}  // namespace
}  // namespace aqs
