#include "geometry/surface_components.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "mesh/boundary_surface.h"
#include "mesh/lattice.h"
#include "testing/source_data.h"
#include "testing/test_surfaces.h"

namespace aqs {
namespace {

// Every consecutive pair of every loop is a boundary edge, each boundary edge is in
// exactly one loop, and closed loops follow their triangles' edge directions when
// `oriented` (consistently oriented surfaces).
void ExpectLoopsCoverTheBoundary(const Eigen::Matrix3Xi& triangles,
                                 const std::vector<BoundaryLoop>& loops, bool oriented) {
  std::map<std::pair<int, int>, int> uses;  // undirected edge -> number of triangles
  std::set<std::pair<int, int>> directed;
  for (int t = 0; t < triangles.cols(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = triangles(k, t), b = triangles((k + 1) % 3, t);
      ++uses[{std::min(a, b), std::max(a, b)}];
      directed.insert({a, b});
    }
  }
  std::set<std::pair<int, int>> seen;
  for (const BoundaryLoop& loop : loops) {
    const int n = static_cast<int>(loop.vertices.size());
    for (int i = 0; i < loop.num_edges(); ++i) {
      const int a = loop.vertices[i], b = loop.vertices[(i + 1) % n];
      const std::pair<int, int> key(std::min(a, b), std::max(a, b));
      EXPECT_EQ(uses[key], 1) << "edge " << a << "-" << b << " is not a boundary edge";
      EXPECT_TRUE(seen.insert(key).second) << "edge " << a << "-" << b << " in two loops";
      if (oriented) {
        EXPECT_TRUE(directed.count({a, b})) << "edge " << a << "-" << b;
      }
    }
  }
  int boundary_edges = 0;
  for (const auto& [edge, count] : uses) boundary_edges += count == 1;
  EXPECT_EQ(static_cast<int>(seen.size()), boundary_edges);
}

TEST(SurfaceComponentsTest, SeparateSurfacesAndUnusedVertices) {
  const SurfaceMesh a = testing::Icosphere(1, 1.0);
  const SurfaceMesh b = testing::Icosphere(0, 1.0, Eigen::Vector3d(5, 0, 0));
  // Vertices: a's, one unused vertex, b's; triangles: b's first, then a's.
  const int na = a.num_vertices(), nb = b.num_vertices();
  Eigen::Matrix3Xi triangles(3, a.num_triangles() + b.num_triangles());
  triangles << (b.triangles.array() + na + 1).matrix(), a.triangles;
  const SurfaceComponents components = FindSurfaceComponents(na + 1 + nb, triangles);
  ASSERT_EQ(components.num_components(), 2);
  EXPECT_EQ(static_cast<int>(components.vertices[0].size()), na);
  EXPECT_EQ(static_cast<int>(components.vertices[1].size()), nb);
  EXPECT_EQ(components.vertices[0].front(), 0);
  EXPECT_EQ(components.vertices[1].front(), na + 1);
  EXPECT_TRUE(std::is_sorted(components.vertices[1].begin(), components.vertices[1].end()));
  EXPECT_EQ(components.vertex_component[na], -1);
  EXPECT_EQ(components.vertex_component[na + 1], 1);
  for (int t = 0; t < triangles.cols(); ++t) {
    EXPECT_EQ(components.triangle_component[t], t < b.num_triangles() ? 1 : 0);
  }
  EXPECT_EQ(FindSurfaceComponents(3, Eigen::Matrix3Xi(3, 0)).num_components(), 0);
}

TEST(BoundaryLoopsTest, SimpleShapes) {
  // One triangle: one loop in its own direction.
  Eigen::Matrix3Xi triangle(3, 1);
  triangle << 4, 7, 2;
  std::vector<BoundaryLoop> loops = FindBoundaryLoops(triangle);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_TRUE(loops[0].closed);
  EXPECT_EQ(loops[0].vertices, (std::vector<int>{4, 7, 2}));
  // With a degenerate triangle on one of its edges: the same loop (its edges 4-4 and
  // 4-7 made 4-7 look shared).
  Eigen::Matrix3Xi with_degenerate(3, 2);
  with_degenerate << 4, 4,  //
      7, 4,                 //
      2, 7;
  loops = FindBoundaryLoops(with_degenerate);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_TRUE(loops[0].closed);
  EXPECT_EQ(loops[0].vertices, (std::vector<int>{4, 7, 2}));
  // A square of two triangles: 4 edges.
  Eigen::Matrix3Xi square(3, 2);
  square << 0, 0,  //
      1, 2,        //
      2, 3;
  loops = FindBoundaryLoops(square);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_EQ(loops[0].vertices, (std::vector<int>{0, 1, 2, 3}));
  ExpectLoopsCoverTheBoundary(square, loops, true);
  // Closed surfaces have none.
  EXPECT_TRUE(FindBoundaryLoops(testing::Icosphere(2, 1.0).triangles).empty());
  LatticeOptions options;
  options.nx = 2;
  options.ny = 3;
  options.nz = 2;
  EXPECT_TRUE(
      FindBoundaryLoops(ExtractBoundarySurface(MakeLatticeMesh(options)).triangles).empty());
}

TEST(BoundaryLoopsTest, HolesInASphere) {
  const SurfaceMesh sphere = testing::Icosphere(3, 1.0);
  // Two separate single-triangle holes and one hole of two adjacent triangles (find a
  // neighbour of triangle 600 through a shared edge).
  int neighbour = -1;
  for (int t = 0; t < sphere.num_triangles() && neighbour < 0; ++t) {
    if (t == 600) continue;
    int shared = 0;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) shared += sphere.triangles(i, t) == sphere.triangles(j, 600);
    }
    if (shared == 2) neighbour = t;
  }
  ASSERT_GE(neighbour, 0);
  const Eigen::Matrix3Xi open =
      testing::RemoveTriangles(sphere.triangles, {0, 1279, 600, neighbour});
  const std::vector<BoundaryLoop> loops = FindBoundaryLoops(open);
  ASSERT_EQ(loops.size(), 3u);
  std::vector<int> sizes;
  for (const BoundaryLoop& loop : loops) {
    EXPECT_TRUE(loop.closed);
    sizes.push_back(loop.num_edges());
  }
  std::sort(sizes.begin(), sizes.end());
  EXPECT_EQ(sizes, (std::vector<int>{3, 3, 4}));
  ExpectLoopsCoverTheBoundary(open, loops, true);
}

TEST(BoundaryLoopsTest, TouchingHolesAndNonManifoldEdges) {
  // Two triangles sharing only vertex 0 (a bow tie): two loops of 3.
  Eigen::Matrix3Xi bow_tie(3, 2);
  bow_tie << 0, 0,  //
      1, 3,         //
      2, 4;
  std::vector<BoundaryLoop> loops = FindBoundaryLoops(bow_tie);
  ASSERT_EQ(loops.size(), 2u);
  EXPECT_EQ(loops[0].vertices, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(loops[1].vertices, (std::vector<int>{0, 3, 4}));
  // Three triangles on edge 0-1 (non-manifold): its six other edges are boundary edges
  // and vertices 0 and 1 have three each, so some chain stays open.
  Eigen::Matrix3Xi fin(3, 3);
  fin << 0, 1, 0,  //
      1, 0, 1,     //
      2, 3, 4;
  loops = FindBoundaryLoops(fin);
  int edges = 0;
  bool any_open = false;
  for (const BoundaryLoop& loop : loops) {
    edges += loop.num_edges();
    any_open = any_open || !loop.closed;
  }
  EXPECT_EQ(edges, 6);
  EXPECT_TRUE(any_open);
  ExpectLoopsCoverTheBoundary(fin, loops, false);
  // Inconsistent orientation (second triangle flipped): still one loop of 4.
  Eigen::Matrix3Xi flipped(3, 2);
  flipped << 0, 0,  //
      1, 3,         //
      2, 2;
  loops = FindBoundaryLoops(flipped);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_TRUE(loops[0].closed);
  EXPECT_EQ(loops[0].num_edges(), 4);
  ExpectLoopsCoverTheBoundary(flipped, loops, false);
}

TEST(IctFaceTest, SkinHasThreeBoundaryLoops) {
  SurfaceMesh skin;
  ASSERT_TRUE(testing::ReadIctFaceDemo("skin_neutral.obj", &skin));
  EXPECT_EQ(skin.num_vertices(), 13294);
  const std::vector<BoundaryLoop> loops = FindBoundaryLoops(skin.triangles);
  std::vector<int> sizes;
  for (const BoundaryLoop& loop : loops) {
    EXPECT_TRUE(loop.closed);
    sizes.push_back(loop.num_edges());
  }
  std::sort(sizes.begin(), sizes.end());
  EXPECT_EQ(sizes, (std::vector<int>{42, 42, 54}));
  ExpectLoopsCoverTheBoundary(skin.triangles, loops, true);
  EXPECT_EQ(FindSurfaceComponents(skin.num_vertices(), skin.triangles).num_components(), 1);
}

TEST(IctFaceTest, UpperAndLowerTeethAreSeparateComponents) {
  SurfaceMesh teeth;
  ASSERT_TRUE(testing::ReadIctFaceDemo("teeth_neutral.obj", &teeth));
  const SurfaceComponents components = FindSurfaceComponents(teeth.num_vertices(), teeth.triangles);
  EXPECT_TRUE(FindBoundaryLoops(teeth.triangles).empty());  // every tooth is closed
  // Split the components at the largest gap between their mean heights (+y is up).
  const int n = components.num_components();
  ASSERT_GE(n, 2);
  std::vector<std::pair<double, int>> heights;
  for (int c = 0; c < n; ++c) {
    double sum = 0;
    for (int v : components.vertices[c]) sum += teeth.vertices(1, v);
    heights.push_back({sum / components.vertices[c].size(), c});
  }
  std::sort(heights.begin(), heights.end());
  int gap = 0;
  for (int i = 1; i + 1 < n; ++i) {
    if (heights[i + 1].first - heights[i].first > heights[gap + 1].first - heights[gap].first) {
      gap = i;
    }
  }
  // Lower teeth: heights[0 .. gap]; upper: the rest.
  int counts[2] = {0, 0}, groups[2] = {0, 0};
  double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
  int first[2] = {teeth.num_vertices(), teeth.num_vertices()}, last[2] = {-1, -1};
  for (int i = 0; i < n; ++i) {
    const int g = i <= gap ? 0 : 1;
    ++groups[g];
    for (int v : components.vertices[heights[i].second]) {
      ++counts[g];
      lo[g] = std::min(lo[g], teeth.vertices(1, v));
      hi[g] = std::max(hi[g], teeth.vertices(1, v));
      first[g] = std::min(first[g], v);
      last[g] = std::max(last[g], v);
    }
  }
  std::printf(
      "teeth: %d components; upper: %d components, %d vertices [%d, %d], y in [%.3f, %.3f]; "
      "lower: %d components, %d vertices [%d, %d], y in [%.3f, %.3f]\n",
      n, groups[1], counts[1], first[1], last[1], lo[1], hi[1], groups[0], counts[0], first[0],
      last[0], lo[0], hi[0]);
  EXPECT_EQ(n, 32);
  EXPECT_EQ(groups[0], 16);
  EXPECT_EQ(groups[1], 16);
  // Each jaw is a contiguous vertex range: upper first, then lower.
  EXPECT_EQ(first[1], 0);
  EXPECT_EQ(last[1] + 1, counts[1]);
  EXPECT_EQ(first[0], counts[1]);
  EXPECT_EQ(last[0], teeth.num_vertices() - 1);
  EXPECT_GT(hi[1], hi[0]);
  EXPECT_GT(lo[1], lo[0]);
}

}  // namespace
}  // namespace aqs
