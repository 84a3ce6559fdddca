#include "geometry/triangle_intersections.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "testing/source_data.h"
#include "testing/test_surfaces.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

using Triangle = std::array<Eigen::Vector3d, 3>;
using Pairs = std::vector<std::pair<int, int>>;

bool Intersect(const Triangle& a, const Triangle& b) {
  return TrianglesIntersect(a[0], a[1], a[2], b[0], b[1], b[2]);
}

// The six vertex orders of t: three rotations of each orientation.
std::vector<Triangle> VertexOrders(const Triangle& t) {
  std::vector<Triangle> orders;
  for (int r = 0; r < 3; ++r) {
    orders.push_back({t[r], t[(r + 1) % 3], t[(r + 2) % 3]});
    orders.push_back({t[r], t[(r + 2) % 3], t[(r + 1) % 3]});
  }
  return orders;
}

// The number of the 72 ways to call TrianglesIntersect on a and b (vertex orders of
// both, either triangle first) that do not answer `expected`.
int CountWrongOrders(const Triangle& a, const Triangle& b, bool expected) {
  int wrong = 0;
  for (const Triangle& x : VertexOrders(a)) {
    for (const Triangle& y : VertexOrders(b)) {
      wrong += Intersect(x, y) != expected;
      wrong += Intersect(y, x) != expected;
    }
  }
  return wrong;
}

#define EXPECT_INTERSECT(a, b) EXPECT_EQ(CountWrongOrders(a, b, true), 0)
#define EXPECT_NO_INTERSECT(a, b) EXPECT_EQ(CountWrongOrders(a, b, false), 0)

Triangle Shifted(const Triangle& t, const Eigen::Vector3d& shift) {
  return {t[0] + shift, t[1] + shift, t[2] + shift};
}

// The unit right triangle in the plane z = 0.
const Triangle kUnit = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                        Eigen::Vector3d(0, 1, 0)};

// Separating-axis test for non-degenerate triangles: they are disjoint exactly when
// their projections onto one of the normals, the edge-edge cross products or the
// in-plane edge normals are disjoint. Exact for small integer coordinates.
bool SeparatingAxisIntersect(const Triangle& a, const Triangle& b) {
  const Eigen::Vector3d na = (a[1] - a[0]).cross(a[2] - a[0]);
  const Eigen::Vector3d nb = (b[1] - b[0]).cross(b[2] - b[0]);
  std::vector<Eigen::Vector3d> axes = {na, nb};
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d ea = a[(i + 1) % 3] - a[i];
    const Eigen::Vector3d eb = b[(i + 1) % 3] - b[i];
    axes.push_back(na.cross(ea));
    axes.push_back(nb.cross(eb));
    for (int j = 0; j < 3; ++j) axes.push_back(ea.cross(b[(j + 1) % 3] - b[j]));
  }
  for (const Eigen::Vector3d& axis : axes) {
    if (axis.squaredNorm() == 0) continue;
    const double a0 = axis.dot(a[0]), a1 = axis.dot(a[1]), a2 = axis.dot(a[2]);
    const double b0 = axis.dot(b[0]), b1 = axis.dot(b[1]), b2 = axis.dot(b[2]);
    if (std::max({a0, a1, a2}) < std::min({b0, b1, b2}) ||
        std::max({b0, b1, b2}) < std::min({a0, a1, a2})) {
      return false;
    }
  }
  return true;
}

Triangle SurfaceTriangle(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                         int t) {
  return {vertices.col(triangles(0, t)), vertices.col(triangles(1, t)),
          vertices.col(triangles(2, t))};
}

bool ShareVertex(const Eigen::Matrix3Xi& triangles, int i, int j) {
  for (int k = 0; k < 3; ++k) {
    for (int l = 0; l < 3; ++l) {
      if (triangles(k, i) == triangles(l, j)) return true;
    }
  }
  return false;
}

// The O(M^2) references.
Pairs BruteForceSelfIntersections(const Eigen::Matrix3Xd& vertices,
                                  const Eigen::Matrix3Xi& triangles, bool skip_adjacent) {
  Pairs pairs;
  for (int i = 0; i < triangles.cols(); ++i) {
    for (int j = i + 1; j < triangles.cols(); ++j) {
      if (skip_adjacent && ShareVertex(triangles, i, j)) continue;
      if (Intersect(SurfaceTriangle(vertices, triangles, i),
                    SurfaceTriangle(vertices, triangles, j))) {
        pairs.emplace_back(i, j);
      }
    }
  }
  return pairs;
}

Pairs BruteForceIntersections(const Eigen::Matrix3Xd& vertices_a,
                              const Eigen::Matrix3Xi& triangles_a,
                              const Eigen::Matrix3Xd& vertices_b,
                              const Eigen::Matrix3Xi& triangles_b) {
  Pairs pairs;
  for (int i = 0; i < triangles_a.cols(); ++i) {
    for (int j = 0; j < triangles_b.cols(); ++j) {
      if (Intersect(SurfaceTriangle(vertices_a, triangles_a, i),
                    SurfaceTriangle(vertices_b, triangles_b, j))) {
        pairs.emplace_back(i, j);
      }
    }
  }
  return pairs;
}

Pairs SelfIntersections(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                        bool skip_adjacent, int num_threads) {
  TriangleIntersectionOptions options;
  options.skip_adjacent = skip_adjacent;
  options.num_threads = num_threads;
  Pairs pairs;
  const int count = FindIntersectingTrianglePairs(vertices, triangles, options, &pairs);
  EXPECT_EQ(count, static_cast<int>(pairs.size()));
  EXPECT_EQ(FindIntersectingTrianglePairs(vertices, triangles, options, nullptr), count);
  return pairs;
}

TEST(TrianglesIntersectTest, CrossingAndDisjoint) {
  // b stands in the plane x = 1/4 and cuts a's plane in y in [-1, 1], over a's [0, 3/4].
  const Triangle crossing = {Eigen::Vector3d(0.25, -1, -1), Eigen::Vector3d(0.25, -1, 1),
                             Eigen::Vector3d(0.25, 2, 0.5)};
  EXPECT_INTERSECT(kUnit, crossing);
  // The planes still cross, each triangle crosses the other's plane, but the two cuts
  // on the common line are apart (beyond either end of a's).
  EXPECT_NO_INTERSECT(kUnit, Shifted(crossing, Eigen::Vector3d(0, 1.8, 0)));
  EXPECT_NO_INTERSECT(kUnit, Shifted(crossing, Eigen::Vector3d(0, -1.05, 0)));
  // A triangle piercing the other through its interior, touching none of its edges.
  const Triangle spike = {Eigen::Vector3d(0.2, 0.2, -1), Eigen::Vector3d(0.3, 0.2, 1),
                          Eigen::Vector3d(0.2, 0.3, 1)};
  EXPECT_INTERSECT(kUnit, spike);
  EXPECT_NO_INTERSECT(kUnit, Shifted(spike, Eigen::Vector3d(0, 0, 1.5)));
  EXPECT_NO_INTERSECT(kUnit, Shifted(spike, Eigen::Vector3d(0.6, 0.6, 0)));
  // Parallel planes; far apart.
  EXPECT_NO_INTERSECT(kUnit, Shifted(kUnit, Eigen::Vector3d(0, 0, 1)));
  EXPECT_NO_INTERSECT(kUnit, Shifted(kUnit, Eigen::Vector3d(0, 0, 1e-200)));
  EXPECT_NO_INTERSECT(kUnit, Shifted(kUnit, Eigen::Vector3d(5, 5, 5)));
}

TEST(TrianglesIntersectTest, TouchingCounts) {
  using V = Eigen::Vector3d;
  // Vertex on vertex.
  EXPECT_INTERSECT(kUnit, Triangle({V(0, 0, 0), V(-1, 0, 0.5), V(0, -1, 0.7)}));
  // Vertex on the face interior; lifted by 1e-200 it is off.
  const Triangle on_face = {V(0.25, 0.25, 0), V(1, 1, 1), V(0, 1, 1)};
  EXPECT_INTERSECT(kUnit, on_face);
  EXPECT_NO_INTERSECT(kUnit, Shifted(on_face, V(0, 0, 1e-200)));
  // Vertex on an edge; moved off it by 1e-15.
  const Triangle on_edge = {V(0.5, 0, 0), V(0.5, -1, 1), V(0.5, -1, -1)};
  EXPECT_INTERSECT(kUnit, on_edge);
  EXPECT_NO_INTERSECT(kUnit, Shifted(on_edge, V(0, -1e-15, 0)));
  // Edge crossing an edge (not coplanar).
  const Triangle edge_edge = {V(0.5, 0, -1), V(0.5, 0, 1), V(0.5, -1, 0)};
  EXPECT_INTERSECT(kUnit, edge_edge);
  EXPECT_NO_INTERSECT(kUnit, Shifted(edge_edge, V(0, -1e-15, 0)));
  // An edge lying in the face; a shared edge (neighbours in a mesh).
  EXPECT_INTERSECT(kUnit, Triangle({V(0.2, 0.2, 0), V(0.5, 0.2, 0), V(0.3, 0.3, 1)}));
  EXPECT_INTERSECT(kUnit, Triangle({V(0, 0, 0), V(1, 0, 0), V(0.5, -1, 0.3)}));
  // The same triangle.
  EXPECT_INTERSECT(kUnit, kUnit);
}

TEST(TrianglesIntersectTest, Coplanar) {
  using V = Eigen::Vector3d;
  // Overlapping; one inside the other; sharing part of an edge; sharing a vertex.
  EXPECT_INTERSECT(kUnit, Triangle({V(0.2, 0.2, 0), V(1.2, 0.2, 0), V(0.2, 1.2, 0)}));
  EXPECT_INTERSECT(kUnit, Triangle({V(0.1, 0.1, 0), V(0.2, 0.1, 0), V(0.1, 0.2, 0)}));
  EXPECT_INTERSECT(kUnit, Triangle({V(-1, -1, 0), V(3, -1, 0), V(-1, 3, 0)}));
  EXPECT_INTERSECT(kUnit, Triangle({V(0.5, 0.5, 0), V(1, 0, 0), V(1, 1, 0)}));
  EXPECT_INTERSECT(kUnit, Triangle({V(1, 0, 0), V(2, 0, 0), V(2, 1, 0)}));
  // Crossing edges only (a star of David).
  EXPECT_INTERSECT(Triangle({V(0, 0, 0), V(2, 0, 0), V(1, 2, 0)}),
                   Triangle({V(0, 1.5, 0), V(2, 1.5, 0), V(1, -0.5, 0)}));
  // Disjoint although the bounding boxes overlap; the same one vertex 1e-12 away from
  // a's hypotenuse, then on it.
  EXPECT_NO_INTERSECT(kUnit, Triangle({V(0.6, 0.6, 0), V(1, 1, 0), V(0.6, 1, 0)}));
  EXPECT_NO_INTERSECT(kUnit, Triangle({V(0.5, 0.5 + 1e-12, 0), V(1, 1, 0), V(0.2, 1, 0)}));
  EXPECT_INTERSECT(kUnit, Triangle({V(0.5, 0.5, 0), V(1, 1, 0), V(0.2, 1, 0)}));
  // In the oblique plane z = x + 2 y.
  auto on_plane = [](double x, double y) { return V(x, y, x + 2 * y); };
  const Triangle oblique = {on_plane(0, 0), on_plane(1, 0), on_plane(0, 1)};
  EXPECT_INTERSECT(oblique, Triangle({on_plane(0.25, 0.25), on_plane(2, 0), on_plane(0, 2)}));
  EXPECT_INTERSECT(oblique, Triangle({on_plane(0.5, 0.5), on_plane(2, 0), on_plane(2, 2)}));
  EXPECT_NO_INTERSECT(oblique, Triangle({on_plane(0.75, 0.5), on_plane(2, 0), on_plane(2, 2)}));
  EXPECT_NO_INTERSECT(oblique,
                      Triangle({on_plane(-1, -1), on_plane(-0.125, -1), on_plane(-1, -0.125)}));
}

TEST(TrianglesIntersectTest, NearlyParallel) {
  using V = Eigen::Vector3d;
  // b covers a's footprint in planes of slope s = 2^-40 ~ 1e-12 (every corner height
  // below is exact): z = 1e-9 + s x stays above a; z = s (x - 1/2) cuts a along
  // x = 1/2; z = s (x - 3/2) cuts a's plane beyond a; z = s (x - 1) touches a at its
  // vertex (1, 0, 0) only, and z = s (x - 1 - 1e-6) misses it.
  const double s = std::ldexp(1.0, -40);
  auto b = [s](double offset, double slope) {
    return Triangle(
        {V(-1, -1, offset - slope), V(3, -1, offset + 3 * slope), V(-1, 3, offset - slope)});
  };
  EXPECT_NO_INTERSECT(kUnit, b(1e-9, s));
  EXPECT_INTERSECT(kUnit, b(-0.5 * s, s));
  EXPECT_NO_INTERSECT(kUnit, b(-1.5 * s, s));
  EXPECT_INTERSECT(kUnit, b(-s, s));
  EXPECT_NO_INTERSECT(kUnit, b(-s * (1 + 1e-6), s));
  // A sliver 1e-9 high crossed by a triangle standing 1e-10 from its base, and 2e-9
  // from it.
  const Triangle sliver = {V(0, 0, 0), V(1, 0, 0), V(0.5, 1e-9, 0)};
  const Triangle standing = {V(0.2, 1e-10, -1e-9), V(0.8, 1e-10, 1e-9), V(0.5, 1e-10, 1)};
  EXPECT_INTERSECT(sliver, standing);
  EXPECT_NO_INTERSECT(sliver, Shifted(standing, V(0, 2e-9, 0)));
}

TEST(TrianglesIntersectTest, DegenerateTrianglesAreSegmentsOrPoints) {
  using V = Eigen::Vector3d;
  // Segments (collinear corners, the extreme ones anywhere in the order) against a.
  EXPECT_INTERSECT(kUnit, Triangle({V(0.2, 0.2, 1), V(0.2, 0.2, -1), V(0.2, 0.2, 0.3)}));
  EXPECT_NO_INTERSECT(kUnit, Triangle({V(2, 2, -1), V(2, 2, 0), V(2, 2, 1)}));
  EXPECT_NO_INTERSECT(kUnit, Triangle({V(0.2, 0.2, 1), V(0.2, 0.2, 0.5), V(0.2, 0.2, 0.1)}));
  EXPECT_INTERSECT(kUnit, Triangle({V(-1, 0.5, 0), V(-0.5, 0.5, 0), V(0.5, 0.5, 0)}));
  EXPECT_NO_INTERSECT(kUnit, Triangle({V(-1, 0.5, 0), V(-0.5, 0.5, 0), V(-0.1, 0.5, 0)}));
  EXPECT_INTERSECT(kUnit, Triangle({V(-1, 0, 0), V(0, 0, 0), V(-2, 0, 0)}));  // at a vertex
  // Points (three equal corners).
  auto point = [](const V& p) { return Triangle({p, p, p}); };
  EXPECT_INTERSECT(kUnit, point(V(0.25, 0.25, 0)));
  EXPECT_INTERSECT(kUnit, point(V(0.5, 0, 0)));
  EXPECT_INTERSECT(kUnit, point(V(0, 1, 0)));
  EXPECT_NO_INTERSECT(kUnit, point(V(0.25, 0.25, 1e-200)));
  EXPECT_NO_INTERSECT(kUnit, point(V(0.6, 0.6, 0)));
  // Both degenerate: crossing, skew, collinear overlapping / touching / apart segments,
  // a point on and off a segment, equal and different points.
  const Triangle x_axis = {V(-1, 0, 0), V(0, 0, 0), V(1, 0, 0)};
  EXPECT_INTERSECT(x_axis, Triangle({V(0, -1, 0), V(0, 1, 0), V(0, 0, 0)}));
  EXPECT_INTERSECT(x_axis, Triangle({V(0.3, -1, -2), V(0.3, 1, 2), V(0.3, 0.5, 1)}));
  EXPECT_NO_INTERSECT(x_axis, Triangle({V(0, -1, 1), V(0, 1, 1), V(0, 0, 1)}));
  EXPECT_INTERSECT(x_axis, Triangle({V(0.5, 0, 0), V(2, 0, 0), V(1, 0, 0)}));
  EXPECT_INTERSECT(x_axis, Triangle({V(1, 0, 0), V(2, 0, 0), V(3, 0, 0)}));
  EXPECT_NO_INTERSECT(x_axis, Triangle({V(1.5, 0, 0), V(2, 0, 0), V(3, 0, 0)}));
  EXPECT_NO_INTERSECT(x_axis, Triangle({V(-1, 1, 0), V(0, 1, 0), V(1, 1, 0)}));  // parallel
  EXPECT_INTERSECT(x_axis, point(V(0.5, 0, 0)));
  EXPECT_NO_INTERSECT(x_axis, point(V(0.5, 1e-200, 0)));
  EXPECT_NO_INTERSECT(x_axis, point(V(1 + 1e-15, 0, 0)));
  EXPECT_INTERSECT(point(V(1, 2, 3)), point(V(1, 2, 3)));
  EXPECT_NO_INTERSECT(point(V(1, 2, 3)), point(V(1, 2, 3 + 1e-15)));
}

// Triangles with corners on the grid {0, 1, 2}^3 touch, share edges and are coplanar
// very often; every answer is compared with the separating-axis test (exact there).
TEST(TrianglesIntersectTest, IntegerGridMatchesSeparatingAxes) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> coordinate(0, 2);
  auto random_triangle = [&]() {
    Triangle t;
    for (Eigen::Vector3d& p : t) {
      p = Eigen::Vector3d(coordinate(rng), coordinate(rng), coordinate(rng));
    }
    return t;
  };
  std::vector<Eigen::Vector3d> grid;
  for (int i = 0; i < 27; ++i) grid.emplace_back(i % 3, i / 3 % 3, i / 9);
  int tested = 0, intersecting = 0, coplanar = 0;
  while (tested < 4000) {
    const Triangle a = random_triangle();
    Triangle b = random_triangle();
    if (tested % 2 == 0) {  // b's corners from the grid points in a's plane
      std::vector<Eigen::Vector3d> in_plane;
      const Eigen::Vector3d normal = (a[1] - a[0]).cross(a[2] - a[0]);
      for (const Eigen::Vector3d& p : grid) {
        if (normal.dot(p - a[0]) == 0) in_plane.push_back(p);
      }
      std::uniform_int_distribution<int> pick(0, static_cast<int>(in_plane.size()) - 1);
      for (Eigen::Vector3d& p : b) p = in_plane[pick(rng)];
    }
    const Eigen::Vector3d na = (a[1] - a[0]).cross(a[2] - a[0]);
    const Eigen::Vector3d nb = (b[1] - b[0]).cross(b[2] - b[0]);
    if (na.squaredNorm() == 0 || nb.squaredNorm() == 0) continue;
    ++tested;
    const bool expected = SeparatingAxisIntersect(a, b);
    intersecting += expected;
    coplanar += na.cross(nb).squaredNorm() == 0 && na.dot(b[0] - a[0]) == 0;
    ASSERT_EQ(CountWrongOrders(a, b, expected), 0)
        << "a: " << a[0].transpose() << ", " << a[1].transpose() << ", " << a[2].transpose()
        << "; b: " << b[0].transpose() << ", " << b[1].transpose() << ", " << b[2].transpose();
  }
  // Both answers, and coplanar pairs, were well represented.
  std::printf("%d grid pairs: %d intersect, %d coplanar\n", tested, intersecting, coplanar);
  EXPECT_GT(intersecting, 1000);
  EXPECT_LT(intersecting, 3500);
  EXPECT_GT(coplanar, 1000);
}

// Random triangles in general position: the separating-axis test in floating point is
// reliable there.
TEST(TrianglesIntersectTest, RandomTrianglesMatchSeparatingAxes) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(0, 1);
  auto random_point = [&]() { return Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)); };
  int intersecting = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const Triangle a = {random_point(), random_point(), random_point()};
    const Triangle b = {random_point(), random_point(), random_point()};
    const bool expected = SeparatingAxisIntersect(a, b);
    intersecting += expected;
    ASSERT_EQ(Intersect(a, b), expected) << "trial " << trial;
  }
  EXPECT_GT(intersecting, 2000);
  EXPECT_LT(intersecting, 18000);
}

// b has a corner rounded onto a's plane (within ~1e-16 of it, on either side or on
// it): the answer is a near tie, but exact signs make all 72 orders of the call agree.
TEST(TrianglesIntersectTest, NearTiesAreConsistent) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-1, 1);
  auto random_point = [&]() { return Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)); };
  int intersecting = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Triangle a = {random_point(), random_point(), random_point()};
    const double s = 0.5 * (1 + uniform(rng)), t = 0.5 * (1 - s) * (1 + uniform(rng));
    const Eigen::Vector3d on_a = a[0] + s * (a[1] - a[0]) + t * (a[2] - a[0]);
    // Half the trials: b on the other side of a's plane, touching it near on_a;
    // otherwise b also reaches across.
    const Eigen::Vector3d normal = (a[1] - a[0]).cross(a[2] - a[0]);
    const Eigen::Vector3d side = trial % 2 == 0 ? normal : Eigen::Vector3d(random_point());
    const Triangle b = {on_a, on_a + side + 0.3 * random_point(),
                        on_a + side + 0.3 * random_point()};
    const bool answer = Intersect(a, b);
    intersecting += answer;
    EXPECT_EQ(CountWrongOrders(a, b, answer), 0) << "trial " << trial;
  }
  EXPECT_GT(intersecting, 0);
}

// A soup of small triangles over a shared pool of vertices (each triangle: a vertex and
// two of its nearest neighbours), so that neighbours share vertices and many cross.
void RandomSoup(int num_vertices, int num_triangles, unsigned seed, Eigen::Matrix3Xd* vertices,
                Eigen::Matrix3Xi* triangles) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0, 1);
  vertices->resize(3, num_vertices);
  for (int v = 0; v < num_vertices; ++v) {
    vertices->col(v) = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
  }
  triangles->resize(3, num_triangles);
  std::uniform_int_distribution<int> any_vertex(0, num_vertices - 1);
  std::uniform_int_distribution<int> near(1, 6);
  for (int t = 0; t < num_triangles; ++t) {
    const int v = any_vertex(rng);
    std::vector<std::pair<double, int>> by_distance;
    for (int w = 0; w < num_vertices; ++w) {
      by_distance.emplace_back((vertices->col(w) - vertices->col(v)).squaredNorm(), w);
    }
    std::sort(by_distance.begin(), by_distance.end());
    int i = near(rng), j = near(rng);
    while (j == i) j = near(rng);
    triangles->col(t) = Eigen::Vector3i(v, by_distance[i].second, by_distance[j].second);
  }
}

TEST(TriangleSelfIntersectionsTest, RandomSoupsMatchBruteForce) {
  for (unsigned seed : {1u, 2u, 3u}) {
    Eigen::Matrix3Xd vertices;
    Eigen::Matrix3Xi triangles;
    RandomSoup(250, 400, seed, &vertices, &triangles);
    for (bool skip_adjacent : {true, false}) {
      const Pairs expected = BruteForceSelfIntersections(vertices, triangles, skip_adjacent);
      EXPECT_GT(expected.size(), 20u);
      for (int num_threads : {1, 2, 4}) {
        EXPECT_EQ(SelfIntersections(vertices, triangles, skip_adjacent, num_threads), expected)
            << "seed " << seed << " skip_adjacent " << skip_adjacent << " threads " << num_threads;
      }
    }
  }
}

TEST(TriangleSelfIntersectionsTest, ClosedIcosphereHasNone) {
  const SurfaceMesh sphere = testing::Icosphere(3, 1.0);
  EXPECT_TRUE(SelfIntersections(sphere.vertices, sphere.triangles, true, 2).empty());
  // Without skipping, exactly the pairs of neighbours (sharing a vertex) are found.
  Pairs neighbours;
  for (int i = 0; i < sphere.num_triangles(); ++i) {
    for (int j = i + 1; j < sphere.num_triangles(); ++j) {
      if (ShareVertex(sphere.triangles, i, j)) neighbours.emplace_back(i, j);
    }
  }
  EXPECT_EQ(SelfIntersections(sphere.vertices, sphere.triangles, false, 2), neighbours);
  // Empty surfaces.
  EXPECT_EQ(FindIntersectingTrianglePairs(sphere.vertices, Eigen::Matrix3Xi(3, 0),
                                          TriangleIntersectionOptions(), nullptr),
            0);
}

TEST(TriangleSelfIntersectionsTest, VerticesPushedThroughTheSphereAreFound) {
  SurfaceMesh sphere = testing::Icosphere(2, 1.0);
  // Push the vertices of the top cap down through the bottom of the sphere: the
  // triangles around them become spikes that pierce the lower half.
  std::vector<char> moved(sphere.num_vertices(), 0);
  int num_moved = 0;
  for (int v = 0; v < sphere.num_vertices(); ++v) {
    if (sphere.vertices(2, v) > 0.9) {
      sphere.vertices(2, v) -= 2.3;
      moved[v] = 1;
      ++num_moved;
    }
  }
  ASSERT_GE(num_moved, 1);
  ASSERT_LE(num_moved, 10);
  const Pairs pairs = SelfIntersections(sphere.vertices, sphere.triangles, true, 2);
  std::printf("icosphere with %d vertices pushed through: %d intersecting pairs\n", num_moved,
              static_cast<int>(pairs.size()));
  EXPECT_GT(pairs.size(), 0u);
  EXPECT_EQ(pairs, BruteForceSelfIntersections(sphere.vertices, sphere.triangles, true));
  // Every pair involves a triangle with a moved vertex, and some reach the bottom.
  auto touches_moved = [&](int t) {
    return moved[sphere.triangles(0, t)] || moved[sphere.triangles(1, t)] ||
           moved[sphere.triangles(2, t)];
  };
  bool reaches_bottom = false;
  for (const auto& [i, j] : pairs) {
    EXPECT_TRUE(touches_moved(i) || touches_moved(j)) << i << " " << j;
    for (int t : {i, j}) {
      if (!touches_moved(t)) {
        for (int k = 0; k < 3; ++k) {
          reaches_bottom |= sphere.vertices(2, sphere.triangles(k, t)) < -0.5;
        }
      }
    }
  }
  EXPECT_TRUE(reaches_bottom);
}

TEST(TriangleSurfaceIntersectionsTest, InterpenetratingIcospheres) {
  const SurfaceMesh a = testing::Icosphere(3, 1.0);
  const SurfaceMesh b = testing::Icosphere(3, 1.0, Eigen::Vector3d(1, 0, 0));
  Pairs pairs;
  const int count =
      FindIntersectingTrianglePairs(a.vertices, a.triangles, b.vertices, b.triangles, 2, &pairs);
  std::printf("two unit icospheres (%d triangles each) 1 apart: %d intersecting pairs\n",
              a.num_triangles(), count);
  EXPECT_EQ(count, static_cast<int>(pairs.size()));
  EXPECT_EQ(pairs, BruteForceIntersections(a.vertices, a.triangles, b.vertices, b.triangles));
  // The spheres meet in the circle x = 1/2, of circumference 2 pi sqrt(3/4) ~ 5.4, which
  // crosses at least one triangle per edge length (~0.12) of each surface.
  EXPECT_GT(count, 40);
  std::set<int> in_a, in_b;
  for (const auto& [i, j] : pairs) {
    in_a.insert(i);
    in_b.insert(j);
    for (const Eigen::Vector3d& p : SurfaceTriangle(a.vertices, a.triangles, i)) {
      EXPECT_LT(std::abs(p(0) - 0.5), 0.2);
    }
  }
  EXPECT_GT(in_a.size(), 40u);
  EXPECT_GT(in_b.size(), 40u);
  // The same pairs the other way round; multi-threaded like single-threaded.
  Pairs swapped;
  FindIntersectingTrianglePairs(b.vertices, b.triangles, a.vertices, a.triangles, 3, &swapped);
  for (auto& pair : swapped) std::swap(pair.first, pair.second);
  std::sort(swapped.begin(), swapped.end());
  EXPECT_EQ(swapped, pairs);
  Pairs serial;
  FindIntersectingTrianglePairs(a.vertices, a.triangles, b.vertices, b.triangles, 1, &serial);
  EXPECT_EQ(serial, pairs);

  // Apart (a gap of 0.5): none.
  const SurfaceMesh far = testing::Icosphere(3, 1.0, Eigen::Vector3d(2.5, 0, 0));
  EXPECT_EQ(FindIntersectingTrianglePairs(a.vertices, a.triangles, far.vertices, far.triangles, 2,
                                          &pairs),
            0);
  EXPECT_TRUE(pairs.empty());
}

TEST(TriangleSurfaceIntersectionsTest, RandomSoupsMatchBruteForce) {
  Eigen::Matrix3Xd vertices_a, vertices_b;
  Eigen::Matrix3Xi triangles_a, triangles_b;
  RandomSoup(200, 300, 7, &vertices_a, &triangles_a);
  RandomSoup(150, 200, 8, &vertices_b, &triangles_b);
  const Pairs expected = BruteForceIntersections(vertices_a, triangles_a, vertices_b, triangles_b);
  EXPECT_GT(expected.size(), 50u);
  for (int num_threads : {1, 2, 4}) {
    Pairs pairs;
    EXPECT_EQ(FindIntersectingTrianglePairs(vertices_a, triangles_a, vertices_b, triangles_b,
                                            num_threads, &pairs),
              static_cast<int>(expected.size()));
    EXPECT_EQ(pairs, expected);
  }
}

// The self-intersecting triangle pairs of the ICT neutral skin (docs/contact.md).
constexpr int kIctNeutralSelfIntersectingPairs = 124;

TEST(TriangleIntersectionsIctFaceTest, SkinNeutralSelfIntersections) {
  SurfaceMesh skin;
  ASSERT_TRUE(testing::ReadIctFaceDemo("skin_neutral.obj", &skin));
  TriangleIntersectionOptions options;
  options.num_threads = 2;
  Pairs pairs;
  WallTimer timer;
  const int count = FindIntersectingTrianglePairs(skin.vertices, skin.triangles, options, &pairs);
  const double seconds = timer.Seconds();
  std::set<int> involved;
  Eigen::AlignedBox3d left, right;  // where they are, on either side of x = 0
  for (const auto& [i, j] : pairs) {
    for (int t : {i, j}) {
      involved.insert(t);
      for (const Eigen::Vector3d& p : SurfaceTriangle(skin.vertices, skin.triangles, t)) {
        (p(0) < 0 ? left : right).extend(p);
      }
    }
  }
  std::printf(
      "ICT skin_neutral: %d triangles, %d self-intersecting pairs (%d triangles involved), "
      "%.3f s on 2 threads\n",
      skin.num_triangles(), count, static_cast<int>(involved.size()), seconds);
  for (const Eigen::AlignedBox3d* box : {&left, &right}) {
    if (box->isEmpty()) continue;
    std::printf("  in the box x [%.2f, %.2f], y [%.2f, %.2f], z [%.2f, %.2f]\n", box->min()(0),
                box->max()(0), box->min()(1), box->max()(1), box->min()(2), box->max()(2));
  }
  options.num_threads = 1;
  Pairs serial;
  timer.Reset();
  FindIntersectingTrianglePairs(skin.vertices, skin.triangles, options, &serial);
  std::printf("  (%.3f s on 1 thread)\n", timer.Seconds());
  EXPECT_EQ(serial, pairs);
  // What the contact report's figures rest on (docs/contact.md): the ICT neutral's
  // intersecting pairs, all at the two mouth corners, each confirmed by the separating
  // axes.
  EXPECT_EQ(count, static_cast<int>(pairs.size()));
  EXPECT_EQ(count, kIctNeutralSelfIntersectingPairs);
  EXPECT_FALSE(left.isEmpty());
  EXPECT_FALSE(right.isEmpty());
  int unconfirmed = 0;
  for (const auto& [i, j] : pairs) {
    unconfirmed += !SeparatingAxisIntersect(SurfaceTriangle(skin.vertices, skin.triangles, i),
                                            SurfaceTriangle(skin.vertices, skin.triangles, j));
  }
  EXPECT_EQ(unconfirmed, 0);
}

}  // namespace
}  // namespace aqs
