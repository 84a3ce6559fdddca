#include <gtest/gtest.h>

#include <string>

#include "mesh/lattice.h"
#include "mesh/mesh_io.h"
#include "mesh_test_util.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

using testing::Contains;

constexpr char kUnitTetMedit[] =
    "MeshVersionFormatted 2\nDimension 3\nVertices 4\n"
    "0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\nTetrahedra 1\n1 2 3 4 0\nEnd\n";

TEST(ReadTetMeshTest, DispatchesByExtension) {
  testing::TempDir dir;
  const std::string medit = dir.Write("a.MESH", kUnitTetMedit);
  dir.Write("b.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  dir.Write("b.ele", "1 4 0\n1 1 2 3 4\n");
  const std::string gmsh = dir.Write(
      "c.msh",
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n"
      "$EndNodes\n$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n");
  for (const std::string& path : {medit, dir.File("b.node"), dir.File("b.ele"), gmsh}) {
    TetMesh mesh;
    std::string error;
    ASSERT_TRUE(ReadTetMesh(path, &mesh, &error)) << path << ": " << error;
    EXPECT_EQ(mesh.vertices, testing::UnitTet().vertices) << path;
    EXPECT_EQ(mesh.tets, testing::UnitTet().tets) << path;
  }
}

TEST(ReadTetMeshTest, UnknownExtension) {
  TetMesh mesh;
  std::string error;
  EXPECT_FALSE(ReadTetMesh("model.stl", &mesh, &error));
  EXPECT_TRUE(Contains(error, "model.stl: unknown mesh file extension '.stl'")) << error;
  EXPECT_TRUE(Contains(error, ".mesh")) << error;
  EXPECT_TRUE(Contains(error, ".node/.ele")) << error;
  EXPECT_TRUE(Contains(error, ".msh")) << error;
  EXPECT_FALSE(ReadTetMesh("dir.v2/model", &mesh, &error));
  EXPECT_TRUE(Contains(error, "unknown mesh file extension (none)")) << error;
}

TEST(ReadTetMeshTest, ValidatesAfterReading) {
  LatticeOptions options;
  options.nx = options.ny = options.nz = 2;
  TetMesh mesh = MakeLatticeMesh(options);
  std::swap(mesh.tets(1, 5), mesh.tets(2, 5));
  testing::TempDir dir;
  const std::string path = dir.File("inverted.mesh");
  std::string error;
  ASSERT_TRUE(WriteMeditMesh(path, mesh, &error)) << error;
  TetMesh read;
  ASSERT_TRUE(ReadMeditMesh(path, &read, &error)) << error;  // Readers do not judge geometry.
  EXPECT_FALSE(ReadTetMesh(path, &read, &error));
  EXPECT_TRUE(Contains(error, path + ": element 5 (vertices")) << error;
  EXPECT_TRUE(Contains(error, "is inverted")) << error;
  // Reader errors pass through unchanged.
  EXPECT_FALSE(ReadTetMesh(dir.Write("bad.mesh", "Dimension 3\nVertices x\n"), &read, &error));
  EXPECT_TRUE(Contains(error, "bad.mesh:2: expected the number of records after 'Vertices'"))
      << error;
}

}  // namespace
}  // namespace aqs
