// BuildSurfaceFeatures (geometry/surface_features.h): the edges of a triangle surface and
// the inclusion-exclusion weights of its edges and vertices.

#include "geometry/surface_features.h"

#include <gtest/gtest.h>

#include "testing/test_surfaces.h"

namespace aqs {
namespace {

// Every side of every triangle is the edge triangle_edges names.
void ExpectTriangleEdges(const Eigen::Matrix3Xi& triangles, const SurfaceFeatures& features) {
  for (int t = 0; t < triangles.cols(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = triangles(k, t), b = triangles((k + 1) % 3, t);
      const Eigen::Vector2i edge = features.edges.col(features.triangle_edges(k, t));
      EXPECT_EQ(edge, Eigen::Vector2i(std::min(a, b), std::max(a, b))) << t << " " << k;
    }
  }
}

TEST(SurfaceFeaturesTest, AClosedSurfaceCountsEdgesOnceNegativeAndVerticesOnce) {
  const SurfaceMesh sphere = testing::Icosphere(2, 1.0);
  const SurfaceFeatures features = BuildSurfaceFeatures(sphere.triangles, sphere.num_vertices());
  // Euler: V - E + F = 2, and 2 E = 3 F on a closed triangle surface.
  EXPECT_EQ(2 * features.edges.cols(), 3 * sphere.triangles.cols());
  EXPECT_EQ(sphere.num_vertices() - features.edges.cols() + sphere.triangles.cols(), 2);
  EXPECT_TRUE((features.edge_weights.array() == -1.0).all());
  EXPECT_TRUE((features.vertex_weights.array() == 1.0).all());
  for (int i = 1; i < features.edges.cols(); ++i) {
    EXPECT_TRUE(features.edges(0, i - 1) < features.edges(0, i) ||
                (features.edges(0, i - 1) == features.edges(0, i) &&
                 features.edges(1, i - 1) < features.edges(1, i)));
  }
  ExpectTriangleEdges(sphere.triangles, features);
}

TEST(SurfaceFeaturesTest, OpenBoundariesNonManifoldEdgesAndUnusedVertices) {
  // Vertex 5 is used by no triangle. Triangles 0 and 1 make a square (0 1 2 3) with the
  // diagonal (0 2); triangle 2 is a fin on the diagonal (a third face at that edge).
  Eigen::Matrix3Xi triangles(3, 3);
  triangles << 0, 0, 0,  //
      1, 2, 2,           //
      2, 3, 4;
  const SurfaceFeatures features = BuildSurfaceFeatures(triangles, 6);
  ASSERT_EQ(features.edges.cols(), 7);
  ExpectTriangleEdges(triangles, features);
  for (int i = 0; i < 7; ++i) {
    const bool diagonal = features.edges.col(i) == Eigen::Vector2i(0, 2);
    EXPECT_EQ(features.edge_weights[i], diagonal ? -2.0 : 0.0) << features.edges.col(i).transpose();
  }
  // Vertices 0 and 2: 3 faces and 4 edges each; 1, 3, 4: one face, two edges (open).
  const Eigen::VectorXd expected = (Eigen::VectorXd(6) << 0, 0, 0, 0, 0, 0).finished();
  EXPECT_EQ(features.vertex_weights, expected);
  // One triangle alone: nothing but its face counts.
  const SurfaceFeatures one = BuildSurfaceFeatures(Eigen::Matrix3Xi(Eigen::Vector3i(0, 1, 2)), 3);
  EXPECT_TRUE((one.edge_weights.array() == 0.0).all());
  EXPECT_TRUE((one.vertex_weights.array() == 0.0).all());
}

TEST(SurfaceFeaturesDeathTest, AVertexOutOfRangeIsAProgrammerError) {
  ::testing::FLAGS_gtest_death_test_style = "threadsafe";
  EXPECT_DEATH(BuildSurfaceFeatures(Eigen::Matrix3Xi(Eigen::Vector3i(0, 1, 3)), 3),
               "triangle 0 has a vertex out of range");
}

}  // namespace
}  // namespace aqs
