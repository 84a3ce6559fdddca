#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <random>
#include <string>

#include "mesh/lattice.h"
#include "mesh/mesh_io.h"
#include "mesh_test_util.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

using testing::Contains;

// Reads `content` as a .mesh file; returns the error (empty on success).
std::string ReadError(const std::string& content, const std::string& name = "bad.mesh") {
  testing::TempDir dir;
  const std::string path = dir.Write(name, content);
  TetMesh mesh;
  std::string error;
  EXPECT_FALSE(ReadMeditMesh(path, &mesh, &error)) << "accepted:\n" << content;
  EXPECT_TRUE(Contains(error, path)) << error;
  return error;
}

TEST(MeditReadTest, CommentsSplitLinesAndSkippedSections) {
  testing::TempDir dir;
  const std::string path = dir.Write("a.mesh",
                                     "# a comment line\n"
                                     "MeshVersionFormatted\n2\n"
                                     "Dimension\n"
                                     "3   # trailing comment\n\n"
                                     "Vertices\n5\n"
                                     "0 0 0 1\n"
                                     "1 0 0 1  0 1 0 1\n"  // two records on one line
                                     "0 0\n1 1\n"          // one record over two lines
                                     "-1.5e-1 2.25 0.125 7\n"
                                     "Edges 1 1 2 0\n"
                                     "Triangles\n2\n1 2 3 5\n1 3 4 5\n"
                                     "Corners 2 1 2\n"
                                     "Normals 1 0 0 1\n"
                                     "NormalAtVertices 1 1 1\n"
                                     "Tetrahedra\n2\n"
                                     "1 2 3 4 0\n"
                                     "2 3 4\n5 0\n"
                                     "Hexahedra 0\n"
                                     "End\n"
                                     "anything after End is ignored\n");
  TetMesh mesh;
  std::string error;
  ASSERT_TRUE(ReadMeditMesh(path, &mesh, &error)) << error;
  ASSERT_EQ(mesh.num_vertices(), 5);
  ASSERT_EQ(mesh.num_tets(), 2);
  EXPECT_EQ(mesh.vertices.col(1), Eigen::Vector3d(1, 0, 0));
  EXPECT_EQ(mesh.vertices.col(3), Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(mesh.vertices.col(4), Eigen::Vector3d(-0.15, 2.25, 0.125));
  EXPECT_EQ(mesh.tets.col(0), Eigen::Vector4i(0, 1, 2, 3));
  EXPECT_EQ(mesh.tets.col(1), Eigen::Vector4i(1, 2, 3, 4));
}

TEST(MeditReadTest, TetrahedraBeforeVerticesAndNoEnd) {
  testing::TempDir dir;
  const std::string path = dir.Write("b.mesh",
                                     "MeshVersionFormatted 1 Dimension 3\n"
                                     "Tetrahedra 1 1 2 3 4 0\n"
                                     "Vertices 4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n");
  TetMesh mesh;
  std::string error;
  ASSERT_TRUE(ReadMeditMesh(path, &mesh, &error)) << error;
  EXPECT_EQ(mesh.num_vertices(), 4);
  EXPECT_EQ(mesh.tets.col(0), Eigen::Vector4i(0, 1, 2, 3));

  const std::string bad = dir.Write("c.mesh",
                                    "Dimension 3\nTetrahedra 2\n1 2 3 4 0\n"
                                    "1 2 3 9 0\nVertices 4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n");
  EXPECT_FALSE(ReadMeditMesh(bad, &mesh, &error));
  EXPECT_TRUE(Contains(error, bad + ":4: tetrahedron 2 has vertex index 9 out of range")) << error;
}

TEST(MeditReadTest, WriteThenReadIsBitExact) {
  LatticeOptions options;
  options.type = LatticeType::kBcc;
  options.nx = 3;
  options.ny = 2;
  options.nz = 2;
  TetMesh mesh = MakeLatticeMesh(options);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> jitter(-0.1, 0.1);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    for (int i = 0; i < 3; ++i) mesh.vertices(i, v) += jitter(random) / 3.0;
  }
  mesh.vertices(0, 0) = 1e-300;
  mesh.vertices(1, 0) = -123456789.123456789;
  testing::TempDir dir;
  const std::string path = dir.File("round.mesh");
  std::string error;
  ASSERT_TRUE(WriteMeditMesh(path, mesh, &error)) << error;
  TetMesh read;
  ASSERT_TRUE(ReadMeditMesh(path, &read, &error)) << error;
  ASSERT_EQ(read.num_vertices(), mesh.num_vertices());
  ASSERT_EQ(read.num_tets(), mesh.num_tets());
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    for (int i = 0; i < 3; ++i) ASSERT_EQ(read.vertices(i, v), mesh.vertices(i, v));
  }
  EXPECT_EQ(read.tets, mesh.tets);
}

TEST(MeditReadTest, TruncatedVertices) {
  const std::string error = ReadError(
      "MeshVersionFormatted 2\nDimension 3\nVertices\n3\n"
      "0 0 0 0\n1 0 0 0\n0 1\n");
  EXPECT_TRUE(Contains(error,
                       "bad.mesh:7: expected the z coordinate of vertex 3 of 3 in "
                       "'Vertices'"))
      << error;
  EXPECT_TRUE(Contains(error, "found the end of the file")) << error;
}

TEST(MeditReadTest, NonNumericToken) {
  const std::string error = ReadError("Dimension 3\nVertices 2\n0 0 0 0\n1 x 0 0\n");
  EXPECT_TRUE(Contains(error, "bad.mesh:4: expected the y coordinate of vertex 2 of 2")) << error;
  EXPECT_TRUE(Contains(error, "got 'x'")) << error;
}

TEST(MeditReadTest, ShortTetrahedronRunsIntoNextKeyword) {
  const std::string error = ReadError(
      "Dimension 3\nVertices 4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"
      "Tetrahedra 1\n1 2 3 4\nEnd\n");
  EXPECT_TRUE(Contains(error, "bad.mesh:9: expected the reference of tetrahedron 1 of 1")) << error;
  EXPECT_TRUE(Contains(error, "got 'End'")) << error;
}

TEST(MeditReadTest, IndexOutOfRange) {
  const std::string error = ReadError(
      "Dimension 3\nVertices 4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"
      "Tetrahedra 2\n1 2 3 4 0\n1 2 5 4 0\nEnd\n");
  EXPECT_TRUE(Contains(error, "bad.mesh:9: tetrahedron 2 has vertex index 5 out of range"))
      << error;
  const std::string zero = ReadError(
      "Dimension 3\nVertices 4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"
      "Tetrahedra 1\n0 1 2 3 0\nEnd\n");
  EXPECT_TRUE(Contains(zero,
                       "bad.mesh:8: tetrahedron 1 has vertex index 0 out of range: "
                       "indices are 1-based"))
      << zero;
}

TEST(MeditReadTest, BadCounts) {
  std::string error = ReadError("Dimension 3\nVertices -4\n");
  EXPECT_TRUE(Contains(error,
                       "bad.mesh:2: the number of records in 'Vertices' must not be "
                       "negative"))
      << error;
  error = ReadError("Dimension 3\nVertices\n\n  2000000000\n0 0 0 0\n");
  EXPECT_TRUE(Contains(error,
                       "bad.mesh:4: the number of records in 'Vertices' (2000000000) is "
                       "larger than the file"))
      << error;
  error = ReadError("Dimension 3\nVertices 99999999999999999999\n");
  EXPECT_TRUE(Contains(error,
                       "bad.mesh:2: expected the number of records after 'Vertices' (an "
                       "integer)"))
      << error;
}

TEST(MeditReadTest, UnknownKeywordAndDimension) {
  std::string error = ReadError("MeshVersionFormatted 2\n\nDimension 3\nVerticies 0\n");
  EXPECT_TRUE(Contains(error, "bad.mesh:4: unknown keyword 'Verticies'")) << error;
  error = ReadError("MeshVersionFormatted 2\nDimension 2\nVertices 0\n");
  EXPECT_TRUE(Contains(error, "bad.mesh:2: Dimension 2 is not supported")) << error;
  error = ReadError("MeshVersionFormatted 2\nDimension\n");
  EXPECT_TRUE(Contains(error, "bad.mesh:2: expected the dimension after 'Dimension'")) << error;
}

TEST(MeditReadTest, MissingSections) {
  std::string error = ReadError("MeshVersionFormatted 2\nDimension 3\nVertices 1 0 0 0 0\nEnd\n");
  EXPECT_TRUE(Contains(error, "no 'Tetrahedra' section")) << error;
  error = ReadError("MeshVersionFormatted 2\nDimension 3\nTetrahedra 0\nEnd\n");
  EXPECT_TRUE(Contains(error, "no 'Vertices' section")) << error;
  error = ReadError("");
  EXPECT_TRUE(Contains(error, "no 'Vertices' section")) << error;
  error = ReadError("Dimension 3\nVertices 0\nVertices 0\n");
  EXPECT_TRUE(Contains(error, "bad.mesh:3: a second 'Vertices' section")) << error;
}

TEST(MeditReadTest, TruncatedSkippedSection) {
  const std::string error = ReadError("Dimension 3\nTriangles 2\n1 2 3 0\n1 2 3\n");
  EXPECT_TRUE(Contains(error, "bad.mesh:4: expected entry 4 of record 2 of 2 in 'Triangles'"))
      << error;
}

TEST(MeditReadTest, BinaryIsRejected) {
  std::string error = ReadError("anything", "mesh.meshb");
  EXPECT_TRUE(Contains(error, "binary")) << error;
  error = ReadError(std::string("\x01\x00\x00\x00\x02\x00\x00\x00", 8), "looks_ascii.mesh");
  EXPECT_TRUE(Contains(error, "binary")) << error;
}

TEST(MeditReadTest, MissingFile) {
  TetMesh mesh;
  std::string error;
  EXPECT_FALSE(ReadMeditMesh("/nonexistent/x.mesh", &mesh, &error));
  EXPECT_TRUE(Contains(error, "/nonexistent/x.mesh")) << error;
}

TEST(MeditWriteTest, Format) {
  testing::TempDir dir;
  const std::string path = dir.File("unit.mesh");
  std::string error;
  ASSERT_TRUE(WriteMeditMesh(path, testing::UnitTet(), &error)) << error;
  std::ifstream in(path);
  const std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content,
            "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n4\n"
            "0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n\n"
            "Tetrahedra\n1\n1 2 3 4 0\n\nEnd\n");
  EXPECT_FALSE(WriteMeditMesh("/nonexistent/dir/x.mesh", testing::UnitTet(), &error));
  EXPECT_TRUE(Contains(error, "/nonexistent/dir/x.mesh")) << error;
}

}  // namespace
}  // namespace aqs
