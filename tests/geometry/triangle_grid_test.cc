#include "geometry/triangle_grid.h"

#include <algorithm>
#include <random>
#include <set>

#include <gtest/gtest.h>

namespace aqs {
namespace {

// The L-infinity distance from p to the bounding box of triangle t.
double BoxDistance(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles, int t,
                   const Eigen::Vector3d& p) {
  Eigen::Vector3d lo = vertices.col(triangles(0, t)), hi = lo;
  for (int k = 1; k < 3; ++k) {
    lo = lo.cwiseMin(vertices.col(triangles(k, t)));
    hi = hi.cwiseMax(vertices.col(triangles(k, t)));
  }
  return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).maxCoeff();
}

// A cell far below the triangles' size would list each triangle in (size / cell)^3 cells
// (a contact radius of 0.003 on the demo face: 2.8 GB): the grid's cells are no smaller
// than the triangles' mean bounding-box side, and still find what the asked-for cell
// would.
TEST(TriangleGridTest, CellsAreNoSmallerThanTheTriangles) {
  Eigen::Matrix3Xd vertices(3, 6);
  vertices << 0, 1, 0, 2, 2.5, 2, 0, 0, 1, 0, 0, 0.5, 0, 0, 0, 1, 1, 1;
  Eigen::Matrix3Xi triangles(3, 2);
  triangles << 0, 3, 1, 4, 2, 5;
  const TriangleGrid grid(vertices, triangles, 1e-3);
  EXPECT_GE(grid.cell(), 0.75);  // the mean of the sides 1 and 0.5
  std::vector<int> marks, near;
  grid.Near(Eigen::Vector3d(0.3, 0.3, 0.0005), 0, &marks, &near);
  EXPECT_NE(std::find(near.begin(), near.end(), 0), near.end());
  // A query far outside the grid finds nothing (its cell stays in int's range).
  grid.Near(Eigen::Vector3d(1e300, -1e300, 0), 1, &marks, &near);
  EXPECT_TRUE(near.empty());
  EXPECT_EQ(TriangleGrid(vertices, triangles, 2.0).cell(), 2.0);
}

TEST(TriangleGridTest, NearFindsEveryTriangleWithinACellOnce) {
  // A soup of small triangles (some degenerate, as segments) in a 4 x 4 x 4 box.
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, 4.0), small(-0.3, 0.3);
  const int num_triangles = 400;
  Eigen::Matrix3Xd vertices(3, 3 * num_triangles);
  Eigen::Matrix3Xi triangles(3, num_triangles);
  for (int t = 0; t < num_triangles; ++t) {
    const Eigen::Vector3d centre(u(rng), u(rng), u(rng));
    for (int k = 0; k < 3; ++k) {
      vertices.col(3 * t + k) = centre + Eigen::Vector3d(small(rng), small(rng), small(rng));
    }
    triangles.col(t) << 3 * t, 3 * t + 1, t % 5 == 0 ? 3 * t + 1 : 3 * t + 2;
  }
  const double cell = 0.5;
  const TriangleGrid grid(vertices, triangles, cell);
  std::vector<int> marks, near;
  int found = 0;
  for (int query = 0; query < 200; ++query) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    grid.Near(p, query, &marks, &near);
    const std::set<int> unique(near.begin(), near.end());
    EXPECT_EQ(unique.size(), near.size()) << "query " << query;
    for (int t = 0; t < num_triangles; ++t) {
      const double d = BoxDistance(vertices, triangles, t, p);
      // Within a cell: found; farther than two cells: not (it would overlap none of the
      // 27 cells around p's).
      if (d <= cell) {
        EXPECT_EQ(unique.count(t), 1u) << "query " << query << " triangle " << t;
      }
      if (d > 2 * cell) {
        EXPECT_EQ(unique.count(t), 0u) << "query " << query << " triangle " << t;
      }
    }
    found += static_cast<int>(near.size());
  }
  EXPECT_GT(found, 200);  // the queries met triangles
  // Marks from another grid size are resized; a query far outside finds nothing.
  std::vector<int> fresh;
  grid.Near(Eigen::Vector3d(50, 50, 50), 0, &fresh, &near);
  EXPECT_TRUE(near.empty());
  EXPECT_EQ(fresh.size(), static_cast<size_t>(num_triangles));
}

// InBox lists every triangle whose bounding box meets the box (and, for a box larger
// than the grid, all of them), each once.
TEST(TriangleGridTest, InBoxFindsEveryTriangleWhoseBoxMeetsIt) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> uniform(0.0, 10.0), small(-0.3, 0.3);
  Eigen::Matrix3Xd vertices(3, 900);
  Eigen::Matrix3Xi triangles(3, 300);
  for (int t = 0; t < 300; ++t) {
    const Eigen::Vector3d centre(uniform(rng), uniform(rng), uniform(rng));
    for (int k = 0; k < 3; ++k) {
      vertices.col(3 * t + k) = centre + Eigen::Vector3d(small(rng), small(rng), small(rng));
    }
    triangles.col(t) << 3 * t, 3 * t + 1, t % 7 == 0 ? 3 * t + 1 : 3 * t + 2;  // some segments
  }
  const TriangleGrid grid(vertices, triangles, 0.7);
  std::vector<int> marks, found;
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d a(uniform(rng), uniform(rng), uniform(rng));
    const Eigen::Vector3d half = (q < 190 ? 0.2 : 30.0) * Eigen::Vector3d(uniform(rng),
                                                                         uniform(rng),
                                                                         uniform(rng));
    const Eigen::Vector3d lo = a - half, hi = a + half;
    grid.InBox(lo, hi, q, &marks, &found);
    const std::set<int> unique(found.begin(), found.end());
    ASSERT_EQ(unique.size(), found.size()) << "query " << q;
    for (int t = 0; t < 300; ++t) {
      Eigen::Vector3d t_lo = vertices.col(triangles(0, t)), t_hi = t_lo;
      for (int k = 1; k < 3; ++k) {
        t_lo = t_lo.cwiseMin(vertices.col(triangles(k, t)));
        t_hi = t_hi.cwiseMax(vertices.col(triangles(k, t)));
      }
      const bool meets = (t_lo.array() <= hi.array()).all() && (lo.array() <= t_hi.array()).all();
      if (meets) {
        EXPECT_EQ(unique.count(t), 1u) << "query " << q << ", triangle " << t;
      }
    }
    if (q >= 190) {
      EXPECT_EQ(found.size(), 300u);  // a box wider than the grid: all
    }
  }
  grid.InBox(Eigen::Vector3d::Constant(1.0), Eigen::Vector3d::Constant(0.0), 500, &marks, &found);
  EXPECT_TRUE(found.empty()) << "an empty box";
}

}  // namespace
}  // namespace aqs
