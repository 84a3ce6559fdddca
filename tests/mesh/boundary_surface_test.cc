#include "mesh/boundary_surface.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <map>
#include <set>
#include <utility>

#include "mesh/lattice.h"
#include "mesh_test_util.h"
#include "testing/test_surfaces.h"

namespace aqs {
namespace {

// Every directed edge of the surface appears once and its reverse once: the surface is
// closed and consistently oriented.
void ExpectClosedAndConsistent(const Eigen::Matrix3Xi& triangles) {
  std::map<std::pair<int, int>, int> directed;
  for (int t = 0; t < triangles.cols(); ++t) {
    for (int i = 0; i < 3; ++i) ++directed[{triangles(i, t), triangles((i + 1) % 3, t)}];
  }
  for (const auto& [edge, count] : directed) {
    EXPECT_EQ(count, 1) << "edge " << edge.first << "-" << edge.second;
    const auto reverse = directed.find({edge.second, edge.first});
    EXPECT_TRUE(reverse != directed.end() && reverse->second == 1)
        << "edge " << edge.first << "-" << edge.second << " is not shared by two triangles";
  }
}

// Oriented triangles as a set, each rotated so that its smallest vertex comes first.
std::set<std::array<int, 3>> OrientedSet(const Eigen::Matrix3Xi& triangles) {
  std::set<std::array<int, 3>> result;
  for (int t = 0; t < triangles.cols(); ++t) {
    std::array<int, 3> v = {triangles(0, t), triangles(1, t), triangles(2, t)};
    std::rotate(v.begin(), std::min_element(v.begin(), v.end()), v.end());
    result.insert(v);
  }
  return result;
}

TEST(BoundarySurfaceTest, SingleTetHasFourOutwardTriangles) {
  const TetMesh mesh = testing::UnitTet();
  const BoundarySurface boundary = ExtractBoundarySurface(mesh);
  ASSERT_EQ(boundary.triangles.cols(), 4);
  EXPECT_EQ(boundary.triangle_tet, std::vector<int>(4, 0));
  EXPECT_EQ(boundary.vertices, (std::vector<int>{0, 1, 2, 3}));
  const Eigen::Vector3d centroid = mesh.vertices.rowwise().mean();
  for (int t = 0; t < 4; ++t) {
    const Eigen::Vector3d x0 = mesh.vertices.col(boundary.triangles(0, t));
    const Eigen::Vector3d x1 = mesh.vertices.col(boundary.triangles(1, t));
    const Eigen::Vector3d x2 = mesh.vertices.col(boundary.triangles(2, t));
    EXPECT_GT((x1 - x0).cross(x2 - x0).dot(x0 - centroid), 0) << "triangle " << t;
  }
  EXPECT_NEAR(testing::EnclosedVolume(mesh.vertices, boundary.triangles), 1.0 / 6.0, 1e-15);
}

class BoundaryLatticeTest : public ::testing::TestWithParam<LatticeType> {};

TEST_P(BoundaryLatticeTest, ClosedOutwardAndComplete) {
  LatticeOptions options;
  options.type = GetParam();
  options.nx = 3;
  options.ny = 2;
  options.nz = 4;
  options.spacing = 0.5;
  options.origin = Eigen::Vector3d(-1, 2, 0.5);
  const TetMesh mesh = MakeLatticeMesh(options);
  const BoundarySurface boundary = ExtractBoundarySurface(mesh);

  // 2 triangles per unit square of the box surface.
  EXPECT_EQ(boundary.triangles.cols(), 2 * 2 * (3 * 2 + 2 * 4 + 3 * 4));
  ASSERT_EQ(boundary.triangle_tet.size(), static_cast<size_t>(boundary.triangles.cols()));
  const double volume = 3 * 2 * 4 * 0.125;
  EXPECT_NEAR(testing::EnclosedVolume(mesh.vertices, boundary.triangles), volume, 1e-12);
  ExpectClosedAndConsistent(boundary.triangles);

  // Each triangle belongs to its element.
  for (int t = 0; t < boundary.triangles.cols(); ++t) {
    const int tet = boundary.triangle_tet[t];
    for (int i = 0; i < 3; ++i) {
      const int v = boundary.triangles(i, t);
      EXPECT_TRUE((mesh.tets.col(tet).array() == v).any());
    }
  }
  // The boundary vertices are exactly the lattice corners on the box surface (BCC
  // centres are all interior).
  std::vector<int> expected;
  for (int k = 0; k <= 4; ++k) {
    for (int j = 0; j <= 2; ++j) {
      for (int i = 0; i <= 3; ++i) {
        if (i == 0 || i == 3 || j == 0 || j == 2 || k == 0 || k == 4) {
          expected.push_back(i + 4 * (j + 3 * k));
        }
      }
    }
  }
  EXPECT_EQ(boundary.vertices, expected);

  // A copy with every element reversed (all negative) gets the same outward triangles.
  TetMesh flipped = mesh;
  flipped.tets.row(0).swap(flipped.tets.row(3));
  const BoundarySurface flipped_boundary = ExtractBoundarySurface(flipped);
  EXPECT_EQ(OrientedSet(flipped_boundary.triangles), OrientedSet(boundary.triangles));
  EXPECT_NEAR(testing::EnclosedVolume(mesh.vertices, flipped_boundary.triangles), volume, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Types, BoundaryLatticeTest,
                         ::testing::Values(LatticeType::kKuhn, LatticeType::kBcc),
                         [](const ::testing::TestParamInfo<LatticeType>& info) {
                           return std::string(info.param == LatticeType::kKuhn ? "Kuhn" : "Bcc");
                         });

TEST(BoundarySurfaceTest, ToSurfaceRenumbersAndUsesGivenPositions) {
  LatticeOptions options;
  options.type = LatticeType::kBcc;
  options.nx = options.ny = options.nz = 2;
  const TetMesh mesh = MakeLatticeMesh(options);
  const BoundarySurface boundary = ExtractBoundarySurface(mesh);
  const Eigen::Matrix3Xd deformed = 2.0 * mesh.vertices;
  const SurfaceMesh surface = BoundaryToSurface(boundary, deformed);
  ASSERT_EQ(surface.num_vertices(), static_cast<int>(boundary.vertices.size()));
  ASSERT_EQ(surface.num_triangles(), boundary.triangles.cols());
  EXPECT_TRUE(surface.face_offsets.empty());
  EXPECT_EQ(surface.num_polygons(), surface.num_triangles());
  for (int i = 0; i < surface.num_vertices(); ++i) {
    EXPECT_EQ(surface.vertices.col(i), deformed.col(boundary.vertices[i]));
  }
  for (int t = 0; t < surface.num_triangles(); ++t) {
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(boundary.vertices[surface.triangles(i, t)], boundary.triangles(i, t));
    }
  }
  EXPECT_NEAR(testing::EnclosedVolume(surface.vertices, surface.triangles), 8.0 * 8.0, 1e-12);
}

}  // namespace
}  // namespace aqs
