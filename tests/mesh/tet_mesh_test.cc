#include "mesh/tet_mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "mesh/lattice.h"
#include "mesh_test_util.h"

namespace aqs {
namespace {

using testing::Contains;
using testing::UnitTet;

TEST(SignedTetVolumeTest, UnitTetAndSwappedOrder) {
  const Eigen::Vector3d x0(0, 0, 0), x1(1, 0, 0), x2(0, 1, 0), x3(0, 0, 1);
  EXPECT_DOUBLE_EQ(SignedTetVolume(x0, x1, x2, x3), 1.0 / 6.0);
  EXPECT_DOUBLE_EQ(SignedTetVolume(x0, x2, x1, x3), -1.0 / 6.0);
  const TetMesh mesh = UnitTet();
  EXPECT_DOUBLE_EQ(SignedTetVolume(mesh, mesh.vertices, 0), 1.0 / 6.0);
  const Eigen::Matrix3Xd scaled = 2.0 * mesh.vertices;
  EXPECT_DOUBLE_EQ(SignedTetVolume(mesh, scaled, 0), 8.0 / 6.0);
}

TEST(ValidateTetMeshTest, AcceptsLatticeAndSingleTet) {
  std::string error;
  EXPECT_TRUE(ValidateTetMesh(UnitTet(), "tet", &error)) << error;
  LatticeOptions options;
  options.nx = 3;
  options.ny = 2;
  options.nz = 2;
  EXPECT_TRUE(ValidateTetMesh(MakeLatticeMesh(options), "lattice", &error)) << error;
}

TEST(ValidateTetMeshTest, AcceptsAllNegativeMesh) {
  LatticeOptions options;
  options.nx = options.ny = options.nz = 2;
  TetMesh mesh = MakeLatticeMesh(options);
  mesh.tets.row(1).swap(mesh.tets.row(2));
  for (int t = 0; t < mesh.num_tets(); ++t) ASSERT_LT(SignedTetVolume(mesh, mesh.vertices, t), 0);
  std::string error;
  EXPECT_TRUE(ValidateTetMesh(mesh, "negative", &error)) << error;
}

TEST(ValidateTetMeshTest, RejectsEmptyMesh) {
  TetMesh mesh = UnitTet();
  mesh.tets.resize(4, 0);
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(mesh, "empty.mesh", &error));
  EXPECT_TRUE(Contains(error, "empty.mesh: "));
  EXPECT_TRUE(Contains(error, "no elements"));
}

TEST(ValidateTetMeshTest, RejectsOutOfRangeIndex) {
  TetMesh mesh = UnitTet();
  mesh.tets(3, 0) = 7;
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(mesh, "m.mesh", &error));
  EXPECT_TRUE(
      Contains(error, "m.mesh: element 0 (vertices 0 1 2 7) has vertex index 7 out of range"))
      << error;
  mesh.tets(3, 0) = -1;
  EXPECT_FALSE(ValidateTetMesh(mesh, "m.mesh", &error));
  EXPECT_TRUE(Contains(error, "vertex index -1 out of range"));
}

TEST(ValidateTetMeshTest, RejectsRepeatedIndex) {
  TetMesh mesh = UnitTet();
  mesh.tets(3, 0) = 1;
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(mesh, "m.mesh", &error));
  EXPECT_TRUE(Contains(error, "element 0 (vertices 0 1 2 1) uses vertex 1 twice")) << error;
}

TEST(ValidateTetMeshTest, RejectsNonFiniteCoordinate) {
  TetMesh mesh = UnitTet();
  mesh.vertices(1, 2) = std::numeric_limits<double>::quiet_NaN();
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(mesh, "m.mesh", &error));
  EXPECT_TRUE(Contains(error, "vertex 2 has a non-finite coordinate")) << error;
}

// A finite coordinate so large that an element's edge lengths overflow is named as that,
// not as a flat element "<= 1e-10 * (longest edge inf)^3".
TEST(ValidateTetMeshTest, RejectsAnElementTooLargeToMeasure) {
  TetMesh mesh = UnitTet();
  mesh.vertices(0, 1) = 1e308;
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(mesh, "big.mesh", &error));
  EXPECT_TRUE(Contains(error, "big.mesh: element 0 (vertices 0 1 2 3) is too large to measure: "
                              "its edge lengths or volume overflow (a coordinate of 1e+308"))
      << error;
  EXPECT_FALSE(Contains(error, "inf")) << error;
}

TEST(ValidateTetMeshTest, RejectsFlatElement) {
  LatticeOptions options;
  options.nx = options.ny = options.nz = 2;
  TetMesh mesh = MakeLatticeMesh(options);
  // Add an element whose four corners are coplanar (z = 0).
  const int a = 0, b = 1, c = 3, d = 4;  // (0,0,0) (1,0,0) (0,1,0) (1,1,0)
  mesh.tets.conservativeResize(4, mesh.num_tets() + 1);
  mesh.tets.col(mesh.num_tets() - 1) << a, b, c, d;
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(mesh, "flat.mesh", &error));
  EXPECT_TRUE(Contains(error, "flat.mesh: element 48 (vertices 0 1 3 4) is flat")) << error;

  // A sliver just above the tolerance passes, just below fails.
  TetMesh sliver = UnitTet();
  sliver.vertices(2, 3) = 1e-6;  // 6V = 1e-6, longest edge sqrt(2)
  TetMeshValidationOptions strict;
  strict.flat_tolerance = 1e-6 / std::pow(std::sqrt(2.0), 3) * 1.01;
  EXPECT_FALSE(ValidateTetMesh(sliver, "s", &error, strict));
  strict.flat_tolerance = 1e-6 / std::pow(std::sqrt(2.0), 3) * 0.99;
  EXPECT_TRUE(ValidateTetMesh(sliver, "s", &error, strict)) << error;
}

TEST(ValidateTetMeshTest, RejectsInvertedElementNamingIt) {
  LatticeOptions options;
  options.nx = options.ny = options.nz = 2;
  TetMesh mesh = MakeLatticeMesh(options);
  ASSERT_EQ(mesh.num_tets(), 48);
  std::swap(mesh.tets(0, 17), mesh.tets(1, 17));
  const std::string vertices =
      std::to_string(mesh.tets(0, 17)) + " " + std::to_string(mesh.tets(1, 17)) + " " +
      std::to_string(mesh.tets(2, 17)) + " " + std::to_string(mesh.tets(3, 17));
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(mesh, "m.mesh", &error));
  EXPECT_TRUE(Contains(error, "m.mesh: element 17 (vertices " + vertices +
                                  ") is inverted: signed volume -0.166667 while 47 other "
                                  "elements are positive"))
      << error;

  // With a negative majority the positive element is the inverted one.
  mesh.tets.row(0).swap(mesh.tets.row(1));
  EXPECT_FALSE(ValidateTetMesh(mesh, "m.mesh", &error));
  EXPECT_TRUE(Contains(error, "element 17 ")) << error;
  EXPECT_TRUE(Contains(error, "while 47 other elements are negative")) << error;
}

TEST(ValidateTetMeshTest, TieCountsPositiveAsMajority) {
  TetMesh mesh;
  mesh.vertices.resize(3, 8);
  mesh.vertices.leftCols(4) = UnitTet().vertices;
  mesh.vertices.rightCols(4) = UnitTet().vertices.colwise() + Eigen::Vector3d(5, 0, 0);
  mesh.tets.resize(4, 2);
  mesh.tets.col(0) << 4, 6, 5, 7;  // negative
  mesh.tets.col(1) << 0, 1, 2, 3;  // positive
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(mesh, "tie", &error));
  EXPECT_TRUE(Contains(error, "element 0 (vertices 4 6 5 7) is inverted")) << error;
}

TEST(ValidateTetMeshTest, RejectsTriangleSharedByThreeElements) {
  TetMesh mesh;
  mesh.vertices.resize(3, 6);
  mesh.vertices << 0, 1, 0, 0.2, 0.2, 0.3,  //
      0, 0, 1, 0.2, 0.2, 0.3,               //
      0, 0, 0, 1, -1, 2;
  mesh.tets.resize(4, 3);
  mesh.tets.col(0) << 0, 1, 2, 3;  // above the triangle 0 1 2
  mesh.tets.col(1) << 0, 2, 1, 4;  // below
  mesh.tets.col(2) << 0, 1, 2, 5;  // above again: overlaps element 0
  for (int t = 0; t < 3; ++t) ASSERT_GT(SignedTetVolume(mesh, mesh.vertices, t), 0);
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(mesh, "nm.mesh", &error));
  EXPECT_TRUE(Contains(error,
                       "nm.mesh: element 2 (vertices 0 1 2 5) shares the triangle (0 1 2) "
                       "with elements 0 and 1"))
      << error;

  // A duplicated element is caught the same way.
  TetMesh duplicated = UnitTet();
  duplicated.tets.conservativeResize(4, 3);
  duplicated.tets.col(1) = duplicated.tets.col(0);
  duplicated.tets.col(2) = duplicated.tets.col(0);
  EXPECT_FALSE(ValidateTetMesh(duplicated, "dup", &error));
  EXPECT_TRUE(Contains(error, "element 2 ")) << error;
}

// Two elements that share a triangle on the same side of it overlap, though no third
// element shares it: an element listed twice, and one folded over a neighbour's face.
TEST(ValidateTetMeshTest, RejectsTwoElementsOnOneSideOfTheirTriangle) {
  TetMesh twice = UnitTet();
  twice.tets.conservativeResize(4, 2);
  twice.tets.col(1) = twice.tets.col(0);
  std::string error;
  EXPECT_FALSE(ValidateTetMesh(twice, "twice", &error));
  EXPECT_TRUE(Contains(error, "twice: element 1 (vertices 0 1 2 3) lies on the same side of the "
                              "triangle"))
      << error;
  EXPECT_TRUE(Contains(error, "as element 0, which shares it: the two overlap")) << error;
  // The unit tet and a second one on its face (0 1 2) whose apex lies inside the first
  // (both positive): folded.
  TetMesh folded;
  folded.vertices.resize(3, 5);
  folded.vertices << 0, 1, 0, 0, 0.2,  //
      0, 0, 1, 0, 0.2,                 //
      0, 0, 0, 1, 0.2;
  folded.tets.resize(4, 2);
  folded.tets.col(0) << 0, 1, 2, 3;
  folded.tets.col(1) << 0, 1, 2, 4;
  for (int t = 0; t < 2; ++t) ASSERT_GT(SignedTetVolume(folded, folded.vertices, t), 0);
  EXPECT_FALSE(ValidateTetMesh(folded, "folded", &error));
  EXPECT_TRUE(Contains(error, "the two overlap")) << error;
  // The same apex below the face: neighbours, accepted.
  folded.vertices.col(4) << 0.2, 0.2, -0.2;
  folded.tets.col(1) << 0, 2, 1, 4;
  ASSERT_GT(SignedTetVolume(folded, folded.vertices, 1), 0);
  EXPECT_TRUE(ValidateTetMesh(folded, "neighbours", &error)) << error;
}

}  // namespace
}  // namespace aqs
