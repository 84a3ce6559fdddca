#include <gtest/gtest.h>

#include <string>

#include "mesh/mesh_io.h"
#include "mesh_test_util.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

using testing::Contains;

constexpr char kNode1[] =
    "# points: 1-based, 1 attribute, markers\n"
    "5 3 1 1\n"
    "1 0 0 0 0.5 1\n"
    "2 1 0 0 0.5 1\n"
    "  3 0 1 0 0.5 0   # comment after a point\n"
    "\n"
    "4 0 0 1 0.5 1\n"
    "5 1 1 1 0.5 1\n";
constexpr char kEle1[] =
    "2 4 1\n"
    "1 1 2 3 4 7\n"
    "# a comment line\n"
    "2 2 5 3 4 7\n";

// Writes stem.node and stem.ele; returns the stem.
std::string WriteTetgen(const testing::TempDir& dir, const std::string& node,
                        const std::string& ele) {
  dir.Write("m.node", node);
  dir.Write("m.ele", ele);
  return dir.File("m");
}

std::string ReadError(const std::string& node, const std::string& ele) {
  testing::TempDir dir;
  const std::string stem = WriteTetgen(dir, node, ele);
  TetMesh mesh;
  std::string error;
  EXPECT_FALSE(ReadTetgenMesh(stem, &mesh, &error)) << "accepted:\n" << node << "\n" << ele;
  EXPECT_TRUE(Contains(error, stem)) << error;
  return error;
}

TEST(TetgenReadTest, OneBasedWithAttributesByAnyName) {
  testing::TempDir dir;
  const std::string stem = WriteTetgen(dir, kNode1, kEle1);
  for (const std::string& path : {stem, stem + ".node", stem + ".ele"}) {
    TetMesh mesh;
    std::string error;
    ASSERT_TRUE(ReadTetgenMesh(path, &mesh, &error)) << path << ": " << error;
    ASSERT_EQ(mesh.num_vertices(), 5);
    ASSERT_EQ(mesh.num_tets(), 2);
    EXPECT_EQ(mesh.vertices.col(2), Eigen::Vector3d(0, 1, 0));
    EXPECT_EQ(mesh.vertices.col(4), Eigen::Vector3d(1, 1, 1));
    EXPECT_EQ(mesh.tets.col(0), Eigen::Vector4i(0, 1, 2, 3));
    EXPECT_EQ(mesh.tets.col(1), Eigen::Vector4i(1, 4, 2, 3));
  }
}

// Files named in upper case (T.NODE, T.ELE) are found through either name: before
// 2026-12-07 the reader looked for T.node and said that file could not be opened.
TEST(TetgenReadTest, UpperCaseExtensionsAreKept) {
  testing::TempDir dir;
  dir.Write("T.NODE", kNode1);
  dir.Write("T.ELE", kEle1);
  for (const char* name : {"T.NODE", "T.ELE"}) {
    TetMesh mesh;
    std::string error;
    ASSERT_TRUE(ReadTetgenMesh(dir.File(name), &mesh, &error)) << name << ": " << error;
    EXPECT_EQ(mesh.num_vertices(), 5) << name;
    EXPECT_EQ(mesh.num_tets(), 2) << name;
  }
}

TEST(TetgenReadTest, ZeroBasedAndTenNodeElements) {
  testing::TempDir dir;
  const std::string stem = WriteTetgen(dir, "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 2.5\n",
                                       "1 10 0\n0 0 1 2 3 0 1 2 3 1 2\n");
  TetMesh mesh;
  std::string error;
  ASSERT_TRUE(ReadTetgenMesh(stem + ".ele", &mesh, &error)) << error;
  EXPECT_EQ(mesh.vertices.col(3), Eigen::Vector3d(0, 0, 2.5));
  ASSERT_EQ(mesh.num_tets(), 1);
  EXPECT_EQ(mesh.tets.col(0), Eigen::Vector4i(0, 1, 2, 3));
}

TEST(TetgenReadTest, BadIndexBaseAndNumbering) {
  std::string error = ReadError("2 3 0 0\n2 0 0 0\n3 1 0 0\n", "0 4 0\n");
  EXPECT_TRUE(Contains(error, "m.node:2: the first point index must be 0 or 1")) << error;
  error = ReadError("3 3 0 0\n1 0 0 0\n2 1 0 0\n4 1 0 0\n", "0 4 0\n");
  EXPECT_TRUE(Contains(error, "m.node:4: expected point index 3")) << error;
}

TEST(TetgenReadTest, NodeIndexOutOfRangeNamesLine) {
  std::string error = ReadError(kNode1, "2 4 1\n1 1 2 3 4 7\n\n2 2 6 3 4 7\n");
  EXPECT_TRUE(Contains(error,
                       "m.ele:4: tetrahedron 2 has node index 6 out of range: the .node "
                       "file has 5 points numbered from 1 to 5"))
      << error;
  error = ReadError(kNode1, "1 4 0\n1 0 2 3 4\n");
  EXPECT_TRUE(Contains(error, "m.ele:2: tetrahedron 1 has node index 0 out of range")) << error;
}

TEST(TetgenReadTest, MalformedContent) {
  std::string error = ReadError("5 3 1\n", kEle1);
  EXPECT_TRUE(Contains(error, "m.node:1: expected the .node header")) << error;
  error = ReadError("5 2 0 0\n", kEle1);
  EXPECT_TRUE(Contains(error, "m.node:1: dimension 2 is not supported")) << error;
  error = ReadError("2 3 0 0\n1 0 0 0\n2 1 zero 0\n", kEle1);
  EXPECT_TRUE(Contains(error, "m.node:3: expected the y coordinate (a finite number)")) << error;
  EXPECT_TRUE(Contains(error, "got 'zero'")) << error;
  error = ReadError("3 3 0 0\n1 0 0 0\n2 1 0 0\n", kEle1);
  EXPECT_TRUE(Contains(error, "m.node:3: expected point 3 of 3")) << error;
  EXPECT_TRUE(Contains(error, "found the end of the file")) << error;
  error = ReadError("2 3 0 0\n1 0 0 0\n2 1 0 0 9\n", kEle1);
  EXPECT_TRUE(Contains(error, "m.node:3: expected 'index x y z' followed by 0 attributes"))
      << error;
  error = ReadError("-2 3 0 0\n", kEle1);
  EXPECT_TRUE(Contains(error, "m.node:1: the number of points must not be negative")) << error;
  error = ReadError("100000000 3 0 0\n1 0 0 0\n", kEle1);
  EXPECT_TRUE(Contains(error,
                       "m.node:1: the number of points (100000000) is larger than the "
                       "file"))
      << error;
  error = ReadError(kNode1, "2 6 1\n");
  EXPECT_TRUE(Contains(error, "m.ele:1: the number of nodes per tetrahedron must be 4 or 10"))
      << error;
  error = ReadError(kNode1, "2 4 1\n1 1 2 3 4 7\n# a long enough comment\n");
  EXPECT_TRUE(Contains(error, "m.ele:3: expected tetrahedron 2 of 2")) << error;
  EXPECT_TRUE(Contains(error, "found the end of the file")) << error;
  error = ReadError(kNode1, "2 4 1\n1 1 2 3 4 7\n");
  EXPECT_TRUE(Contains(error,
                       "m.ele:1: the number of tetrahedra (2) is larger than the file "
                       "(18 bytes) can hold: the file is truncated"))
      << error;
  error = ReadError(kNode1, "2 4 1\n1 1 2 3 4 7\n2 1 2 3\n");
  EXPECT_TRUE(Contains(error, "m.ele:3: expected 'index' and 4 node indices")) << error;
}

// Decided leniencies are errors: element numbers out of sequence, records beyond the
// header's counts, hexadecimal numbers.
TEST(TetgenReadTest, ElementNumberingTrailingRecordsAndHexAreErrors) {
  std::string error = ReadError(kNode1, "2 4 1\n1 1 2 3 4 7\n7 2 5 3 4 7\n");
  EXPECT_TRUE(Contains(error, "m.ele:3: expected tetrahedron index 2")) << error;
  error = ReadError(kNode1, "1 4 1\n1 1 2 3 4 7\n2 2 5 3 4 7\n");
  EXPECT_TRUE(Contains(error, "m.ele:3: content after the 1 tetrahedra the header declares"))
      << error;
  error = ReadError("2 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n", "0 4 0\n");
  EXPECT_TRUE(Contains(error, "m.node:4: content after the 2 points the header declares"))
      << error;
  error = ReadError("2 3 0 0\n1 0 0 0\n2 0x10 0 0\n", kEle1);
  EXPECT_TRUE(Contains(error, "m.node:3: expected the x coordinate (a finite number)")) << error;
  error = ReadError(kNode1, "2 4 1\n1 1 2 3 4 7\n2 2 0x5 3 4 7\n");
  EXPECT_TRUE(Contains(error, "m.ele:3: expected a node index (an integer)")) << error;
  // Comments and blank lines after the records are fine.
  testing::TempDir dir;
  const std::string stem = WriteTetgen(dir, std::string(kNode1) + "\n# end\n",
                                       std::string(kEle1) + "# generated\n\n");
  TetMesh mesh;
  ASSERT_TRUE(ReadTetgenMesh(stem, &mesh, &error)) << error;
}

TEST(TetgenReadTest, MissingEleFile) {
  testing::TempDir dir;
  dir.Write("only.node", kNode1);
  TetMesh mesh;
  std::string error;
  EXPECT_FALSE(ReadTetgenMesh(dir.File("only.node"), &mesh, &error));
  EXPECT_TRUE(Contains(error, dir.File("only.ele"))) << error;
}

}  // namespace
}  // namespace aqs
