#include <gtest/gtest.h>

#include <string>

#include "mesh/mesh_io.h"
#include "mesh_test_util.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

using testing::Contains;

// Format 2.2: non-contiguous node tags; points, lines, triangles, a 4-node and a
// 10-node tet; a physical names section and an unknown section that are skipped.
constexpr char kGmsh22[] =
    "$MeshFormat\n"
    "2.2 0 8\n"
    "$EndMeshFormat\n"
    "$PhysicalNames\n"
    "1\n"
    "3 1 \"solid $Nodes\"\n"
    "$EndPhysicalNames\n"
    "$Nodes\n"
    "6\n"
    "10 0 0 0\n"
    "20 1 0 0\n"
    "30 0 1 0\n"
    "40 0 0 1\n"
    "7 1 1 1\n"
    "1000000000 0.5 0.5 0.5\n"
    "$EndNodes\n"
    "$SomethingElse\n"
    "whatever 1 2 3\n"
    "$EndSomethingElse\n"
    "$Elements\n"
    "5\n"
    "1 15 2 0 1 10\n"
    "2 1 2 0 1 10 20\n"
    "3 2 2 0 1 10 20 30\n"
    "4 4 2 1 1 10 20 30 40\n"
    "5 11 3 1 1 0 20 7 30 40 10 20 30 40 10 20\n"
    "$EndElements\n";

// Format 4.1: entities skipped, two node blocks (one parametric), a triangle block and
// a tet block.
constexpr char kGmsh41[] =
    "$MeshFormat\n"
    "4.1 0 8\n"
    "$EndMeshFormat\n"
    "$Entities\n"
    "1 0 0 1\n"
    "1 0 0 0 0\n"
    "1 0 0 0 1 1 1 0 0\n"
    "$EndEntities\n"
    "$Nodes\n"
    "2 5 3 12\n"
    "3 1 0 3\n"
    "3\n"
    "5\n"
    "8\n"
    "0 0 0\n"
    "1 0 0\n"
    "0 1 0\n"
    "2 1 1 2\n"
    "12\n"
    "4\n"
    "0 0 1 0.25 0.5\n"
    "1 1 1 0.5 0.5\n"
    "$EndNodes\n"
    "$Elements\n"
    "2 3 1 3\n"
    "2 1 2 1\n"
    "1 3 5 8\n"
    "3 1 4 2\n"
    "2 3 5 8 12\n"
    "3 5 12 8 4\n"
    "$EndElements\n";

std::string ReadError(const std::string& content) {
  testing::TempDir dir;
  const std::string path = dir.Write("bad.msh", content);
  TetMesh mesh;
  std::string error;
  EXPECT_FALSE(ReadGmshMesh(path, &mesh, &error)) << "accepted:\n" << content;
  EXPECT_TRUE(Contains(error, path)) << error;
  return error;
}

TEST(GmshReadTest, Version22MixedElementsAndSparseTags) {
  testing::TempDir dir;
  const std::string path = dir.Write("a.msh", kGmsh22);
  TetMesh mesh;
  std::string error;
  ASSERT_TRUE(ReadGmshMesh(path, &mesh, &error)) << error;
  ASSERT_EQ(mesh.num_vertices(), 6);
  EXPECT_EQ(mesh.vertices.col(4), Eigen::Vector3d(1, 1, 1));
  EXPECT_EQ(mesh.vertices.col(5), Eigen::Vector3d(0.5, 0.5, 0.5));
  ASSERT_EQ(mesh.num_tets(), 2);
  EXPECT_EQ(mesh.tets.col(0), Eigen::Vector4i(0, 1, 2, 3));
  EXPECT_EQ(mesh.tets.col(1), Eigen::Vector4i(1, 4, 2, 3));
}

TEST(GmshReadTest, Version41Blocks) {
  testing::TempDir dir;
  const std::string path = dir.Write("a.msh", kGmsh41);
  TetMesh mesh;
  std::string error;
  ASSERT_TRUE(ReadGmshMesh(path, &mesh, &error)) << error;
  ASSERT_EQ(mesh.num_vertices(), 5);
  EXPECT_EQ(mesh.vertices.col(0), Eigen::Vector3d(0, 0, 0));
  EXPECT_EQ(mesh.vertices.col(3), Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(mesh.vertices.col(4), Eigen::Vector3d(1, 1, 1));
  ASSERT_EQ(mesh.num_tets(), 2);
  EXPECT_EQ(mesh.tets.col(0), Eigen::Vector4i(0, 1, 2, 3));
  EXPECT_EQ(mesh.tets.col(1), Eigen::Vector4i(1, 3, 2, 4));
}

TEST(GmshReadTest, BinaryAndUnsupportedVersions) {
  std::string error = ReadError("$MeshFormat\n4.1 1 8\n\x01\x00\x00\x00\n$EndMeshFormat\n");
  EXPECT_TRUE(Contains(error, "bad.msh:2: binary Gmsh files (file type 1) are not supported"))
      << error;
  error = ReadError("$MeshFormat\n4 0 8\n$EndMeshFormat\n");
  EXPECT_TRUE(Contains(error, "bad.msh:2: unsupported Gmsh format version '4'")) << error;
  error = ReadError("$MeshFormat\n2.2 0 8\n");
  EXPECT_TRUE(Contains(error, "bad.msh:2: expected $EndMeshFormat")) << error;
  error = ReadError("$Nodes\n0\n$EndNodes\n");
  EXPECT_TRUE(Contains(error, "bad.msh:1: expected $MeshFormat")) << error;
  error = ReadError("");
  EXPECT_TRUE(Contains(error, "empty file")) << error;
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  return text.replace(pos, from.size(), to);
}

TEST(GmshReadTest, UnknownElementTypeIsNamed) {
  std::string error = ReadError(Replace(kGmsh22, "3 2 2 0 1 10 20 30\n", "3 42 2 0 1 10 20 30\n"));
  EXPECT_TRUE(Contains(error, "bad.msh:24: element 3 has unknown element type 42")) << error;
  error = ReadError(Replace(kGmsh41, "2 1 2 1\n", "2 1 77 1\n"));
  EXPECT_TRUE(Contains(error, "bad.msh:26: element block 1 has unknown element type 77")) << error;
}

TEST(GmshReadTest, UnknownNodeTagNamesLine) {
  std::string error =
      ReadError(Replace(kGmsh22, "4 4 2 1 1 10 20 30 40\n", "4 4 2 1 1 10 20 30 41\n"));
  EXPECT_TRUE(Contains(error,
                       "bad.msh:25: element 4 refers to node tag 41 which is not in "
                       "$Nodes"))
      << error;
  error = ReadError(Replace(kGmsh41, "3 5 12 8 4\n", "3 5 12 8 6\n"));
  EXPECT_TRUE(Contains(error, "bad.msh:30: element 3 refers to node tag 6")) << error;
}

TEST(GmshReadTest, CountsThatDisagreeWithTheSection) {
  // Announces fewer nodes than listed: the next line is not $EndNodes.
  std::string error = ReadError(Replace(kGmsh22, "$Nodes\n6\n", "$Nodes\n5\n"));
  EXPECT_TRUE(Contains(error, "bad.msh:15: expected $EndNodes after 5 nodes")) << error;
  // Announces more: a node line is '$EndNodes'.
  error = ReadError(Replace(kGmsh22, "$Nodes\n6\n", "$Nodes\n7\n"));
  EXPECT_TRUE(Contains(error, "bad.msh:16: expected node 7 of 7 ('tag x y z') (4 entries), got 1"))
      << error;
  error = ReadError(Replace(kGmsh41, "2 5 3 12\n", "2 6 3 12\n"));
  EXPECT_TRUE(Contains(error, "the node blocks hold 5 nodes but the $Nodes header announces 6"))
      << error;
  error = ReadError(Replace(kGmsh22, "$Nodes\n6\n", "$Nodes\n-6\n"));
  EXPECT_TRUE(Contains(error, "bad.msh:9: the number of nodes must not be negative")) << error;
  error = ReadError(Replace(kGmsh22, "$Elements\n5\n", "$Elements\n500000000\n"));
  EXPECT_TRUE(Contains(error,
                       "bad.msh:21: the number of elements (500000000) is larger than the "
                       "file"))
      << error;
}

TEST(GmshReadTest, TruncatedAndMalformed) {
  std::string error =
      ReadError(std::string(kGmsh22).substr(0, std::string(kGmsh22).find("30 0 1 0")));
  EXPECT_TRUE(Contains(error, "expected node 3 of 6")) << error;
  EXPECT_TRUE(Contains(error, "found the end of the file")) << error;
  error = ReadError(Replace(kGmsh22, "20 1 0 0\n", "20 1 0 x\n"));
  EXPECT_TRUE(Contains(error, "bad.msh:11: expected a node coordinate (a finite number), got 'x'"))
      << error;
  error = ReadError(Replace(kGmsh22, "7 1 1 1\n", "10 1 1 1\n"));
  EXPECT_TRUE(Contains(error, "bad.msh:14: node tag 10 appears twice")) << error;
  error = ReadError(Replace(kGmsh22, "$EndSomethingElse\n", ""));
  EXPECT_TRUE(Contains(error,
                       "bad.msh:17: section $SomethingElse is not closed: no "
                       "$EndSomethingElse"))
      << error;
  error = ReadError(Replace(kGmsh22, "$EndElements\n", ""));
  EXPECT_TRUE(Contains(error, "expected $EndElements after 5 elements")) << error;
  error = ReadError(Replace(kGmsh22, "4 4 2 1 1 10 20 30 40\n", "4 4 2 1 1 10 20 30\n"));
  EXPECT_TRUE(Contains(error, "bad.msh:25: element 4 of type 4 with 2 tags needs 9 entries"))
      << error;
  error = ReadError(Replace(kGmsh41, "0 0 1 0.25 0.5\n", "0 0\n"));
  EXPECT_TRUE(Contains(error,
                       "bad.msh:21: expected the coordinates 'x y z u ...' of node 1 of 2 "
                       "in node block 2"))
      << error;
}

TEST(GmshReadTest, NoTetrahedra) {
  std::string content = Replace(kGmsh22, "4 4 2 1 1 10 20 30 40\n", "4 2 2 1 1 10 20 30\n");
  content = Replace(content, "5 11 3 1 1 0 20 7 30 40 10 20 30 40 10 20\n", "5 15 1 0 7\n");
  const std::string error = ReadError(content);
  EXPECT_TRUE(Contains(error, "no tetrahedra (element types 4 or 11)")) << error;
  EXPECT_TRUE(Contains(error, "5 elements of other types")) << error;
}

}  // namespace
}  // namespace aqs
