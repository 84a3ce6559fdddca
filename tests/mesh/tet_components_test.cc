#include "mesh/tet_components.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/test_meshes.h"

namespace aqs {
namespace {

// Two 2 x 1 x 1 bars of unit cubes; the second moved by `offset` (3 apart along x: two
// pieces; 2 apart, sharing the face x = 2: one).
TetMesh TwoBars(const Eigen::Vector3d& offset) {
  const TetMesh bar = testing::BarMesh(2, 1, 1, 1.0);
  TetMesh two;
  const int nv = bar.num_vertices(), nt = bar.num_tets();
  two.vertices.resize(3, 2 * nv);
  two.vertices << bar.vertices, bar.vertices.colwise() + offset;
  two.tets.resize(4, 2 * nt);
  two.tets << bar.tets, bar.tets.array() + nv;
  // Vertices at the same place are one (those left unused do not matter here).
  for (int t = nt; t < 2 * nt; ++t) {
    for (int k = 0; k < 4; ++k) {
      for (int u = 0; u < nv; ++u) {
        if (two.vertices.col(u) == two.vertices.col(two.tets(k, t))) two.tets(k, t) = u;
      }
    }
  }
  return two;
}

std::vector<bool> FixedAt(const TetMesh& mesh, double x) {
  std::vector<bool> fixed(mesh.num_vertices(), false);
  for (int v = 0; v < mesh.num_vertices(); ++v) fixed[v] = mesh.vertices(0, v) == x;
  return fixed;
}

TEST(TetComponentsTest, PiecesAreJoinedByTriangles) {
  std::vector<int> piece;
  const TetMesh apart = TwoBars(Eigen::Vector3d(3, 0, 0));
  EXPECT_EQ(TetMeshPieces(apart, &piece), 2);
  EXPECT_EQ(piece.front(), 0);
  EXPECT_EQ(piece.back(), 1);
  // Sharing only the edge x = 2, y = 1 (the second bar moved up and along): two pieces,
  // which can turn about it.
  const TetMesh hinged = TwoBars(Eigen::Vector3d(2, 1, 0));
  EXPECT_EQ(TetMeshPieces(hinged, &piece), 2);
  EXPECT_EQ(TetMeshPieces(TwoBars(Eigen::Vector3d(2, 0, 0)), &piece), 1);  // a shared face
  EXPECT_EQ(TetMeshPieces(testing::BarMesh(5, 2, 1, 1.0), &piece), 1);
  // Two elements sharing the edge (0, 1) only: two pieces, however the other vertices
  // are numbered (the faces at the shared edge then sort next to each other in a table
  // of faces by their vertices).
  TetMesh two_tets;
  two_tets.vertices.resize(3, 6);
  two_tets.vertices << 0, 1, 0, 0, 0, 0,  //
      0, 0, 1, 0, -1, 0,                  //
      0, 0, 0, 1, 0, -1;
  for (const Eigen::Matrix<int, 4, 2>& tets :
       {(Eigen::Matrix<int, 4, 2>() << 0, 0, 1, 1, 2, 4, 3, 5).finished(),
        (Eigen::Matrix<int, 4, 2>() << 4, 2, 5, 3, 0, 0, 1, 1).finished()}) {
    two_tets.tets = tets;
    EXPECT_EQ(TetMeshPieces(two_tets, &piece), 2) << tets.transpose();
  }
  two_tets.tets << 0, 0, 1, 1, 2, 2, 3, 4;  // sharing the triangle (0, 1, 2): one piece
  EXPECT_EQ(TetMeshPieces(two_tets, &piece), 1);
}

// A piece without 3 fixed vertices off one line is refused, named by an element; fixed
// ends on both pieces hold them.
TEST(TetComponentsTest, EveryPieceMustBeHeld) {
  const TetMesh apart = TwoBars(Eigen::Vector3d(3, 0, 0));
  std::string error;
  std::vector<bool> fixed = FixedAt(apart, 0.0);  // the first bar's end
  EXPECT_FALSE(EveryPieceIsHeld(apart, fixed, &error));
  EXPECT_NE(error.find("the simulation mesh has 2 pieces"), std::string::npos) << error;
  EXPECT_NE(error.find("the piece of element " + std::to_string(apart.num_tets() / 2) +
                       " (0-based; " + std::to_string(apart.num_tets() / 2) +
                       " elements) has fewer than 3 fixed vertices off one line"),
            std::string::npos)
      << error;
  const std::vector<bool> other_end = FixedAt(apart, 5.0);
  for (int v = 0; v < apart.num_vertices(); ++v) fixed[v] = fixed[v] || other_end[v];
  EXPECT_TRUE(EveryPieceIsHeld(apart, fixed, &error)) << error;
  // One line of fixed vertices (an edge of the second bar's end): it could turn about it.
  for (int v = 0; v < apart.num_vertices(); ++v) {
    if (other_end[v] && apart.vertices(1, v) > 0.5) fixed[v] = false;
  }
  EXPECT_FALSE(EveryPieceIsHeld(apart, fixed, &error));
  EXPECT_NE(error.find("fewer than 3 fixed vertices off one line"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
