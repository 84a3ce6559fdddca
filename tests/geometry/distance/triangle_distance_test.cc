#include "geometry/distance/triangle_distance.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

namespace aqs {
namespace {

TEST(SegmentSegmentDistanceTest, KnownCases) {
  const Eigen::Vector3d o(0, 0, 0), x(1, 0, 0);
  // Crossing at a right angle 0.5 above the middle.
  EXPECT_NEAR(SegmentSegmentDistance(o, x, Eigen::Vector3d(0.5, -1, 0.5),
                                     Eigen::Vector3d(0.5, 1, 0.5)), 0.5, 1e-15);
  // Parallel, overlapping, 0.3 apart; parallel, disjoint along the line.
  EXPECT_NEAR(SegmentSegmentDistance(o, x, Eigen::Vector3d(0.5, 0.3, 0),
                                     Eigen::Vector3d(2, 0.3, 0)), 0.3, 1e-15);
  EXPECT_NEAR(SegmentSegmentDistance(o, x, Eigen::Vector3d(3, 0, 0), Eigen::Vector3d(4, 0, 0)),
              2.0, 1e-15);
  // End to end, and a point (degenerate segment) to a segment.
  EXPECT_NEAR(SegmentSegmentDistance(o, x, Eigen::Vector3d(2, 1, 0), Eigen::Vector3d(3, 5, 0)),
              std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(SegmentSegmentDistance(o, x, Eigen::Vector3d(0.25, 0, 2), Eigen::Vector3d(0.25, 0, 2)),
              2.0, 1e-15);
}

// Brute force: the least distance over a dense sampling of both sets (an upper bound
// that converges to the exact distance).
template <typename PointA, typename PointB>
double SampledDistance(PointA point_a, PointB point_b, int n) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; j <= n - (point_a.is_triangle ? i : 0); ++j) {
      const Eigen::Vector3d p = point_a(i / double(n), j / double(n));
      for (int k = 0; k <= n; ++k) {
        for (int l = 0; l <= n - (point_b.is_triangle ? k : 0); ++l) {
          best = std::min(best, (p - point_b(k / double(n), l / double(n))).norm());
        }
      }
    }
  }
  return best;
}

struct TrianglePoints {
  Eigen::Matrix3d corners;
  bool is_triangle = true;
  Eigen::Vector3d operator()(double u, double v) const {
    return corners.col(0) + u * (corners.col(1) - corners.col(0)) + v * (corners.col(2) - corners.col(0));
  }
};

TEST(DisjointTriangleDistanceTest, MatchesDenseSamplingOfRandomTriangles) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial) {
    TrianglePoints a, b;
    for (int k = 0; k < 3; ++k) {
      a.corners.col(k) = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
      b.corners.col(k) = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)) +
                         Eigen::Vector3d(0.8, 0.3, 0.2) * (trial % 4);
    }
    const double exact = DisjointTriangleDistance(a.corners, b.corners);
    const double sampled = SampledDistance(a, b, 24);
    if (sampled < 0.05) continue;  // may intersect
    ++checked;
    EXPECT_LE(exact, sampled + 1e-12) << trial;
    EXPECT_GT(exact, sampled - 0.05) << trial;
  }
  EXPECT_GT(checked, 20);
  // An edge of b runs 0.2 above a, from its corner (1, -1) across it.
  Eigen::Matrix3d a, b;
  a << 0, 2, 1,  0, 0, -1,  0, 0, 0;   // columns: (0,0,0), (2,0,0), (1,-1,0)
  b << 1, 1, 1.5,  -1, 1, 0,  0.2, 0.2, 1.2;
  EXPECT_NEAR(DisjointTriangleDistance(a, b), 0.2, 1e-14);
}

}  // namespace
}  // namespace aqs
