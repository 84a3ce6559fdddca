// Mesh measures (mesh/mesh_measures.h): the mean edge length the decoder's grid and the
// springs scale with, and each surface vertex's share of the area.

#include "mesh/mesh_measures.h"

#include <gtest/gtest.h>

#include "mesh/lattice.h"

namespace aqs {
namespace {

TEST(MeshMeasuresTest, AKuhnLatticeHasMeanEdgeAboutOnePointTwoSixCubes) {
  LatticeOptions lattice;
  lattice.nx = lattice.ny = lattice.nz = 3;
  lattice.spacing = 0.5;
  const double mean = MeanEdgeLength(MakeLatticeMesh(lattice));
  EXPECT_NEAR(mean / 0.5, 1.26, 0.01);
  EXPECT_EQ(MeanEdgeLength(TetMesh()), 0.0);
}

TEST(MeshMeasuresTest, VertexAreasShareEachTriangleInThirds) {
  // A unit square of two triangles and a vertex no triangle uses.
  Eigen::Matrix3Xd vertices(3, 5);
  vertices << 0, 1, 1, 0, 7,  //
      0, 0, 1, 1, 7,          //
      0, 0, 0, 0, 7;
  Eigen::Matrix3Xi triangles(3, 2);
  triangles << 0, 0,  //
      1, 2,           //
      2, 3;
  const Eigen::VectorXd areas = VertexAreas(vertices, triangles);
  ASSERT_EQ(areas.size(), 5);
  EXPECT_NEAR(areas.sum(), 1.0, 1e-15);
  EXPECT_NEAR(areas[0], 1.0 / 3, 1e-15);  // in both triangles
  EXPECT_NEAR(areas[2], 1.0 / 3, 1e-15);
  EXPECT_NEAR(areas[1], 1.0 / 6, 1e-15);
  EXPECT_NEAR(areas[3], 1.0 / 6, 1e-15);
  EXPECT_EQ(areas[4], 0.0);
}

}  // namespace
}  // namespace aqs
