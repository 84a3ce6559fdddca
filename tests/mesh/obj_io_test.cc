#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "mesh/boundary_surface.h"
#include "mesh/lattice.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "mesh_test_util.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

using testing::Contains;

std::string ReadError(const std::string& content) {
  testing::TempDir dir;
  const std::string path = dir.Write("bad.obj", content);
  SurfaceMesh surface;
  std::string error;
  EXPECT_FALSE(ReadObj(path, &surface, &error)) << "accepted:\n" << content;
  EXPECT_TRUE(Contains(error, path)) << error;
  return error;
}

TEST(ObjReadTest, QuadsNegativeIndicesAndCornerForms) {
  testing::TempDir dir;
  const std::string path = dir.Write("a.obj",
                                     "# a cube side and a triangle\n"
                                     "mtllib a.mtl\n"
                                     "o thing\n"
                                     "v 0 0 0\n"
                                     "v 1 0 0 1.0\n"
                                     "v 1 1 0\n"
                                     "v 0 1 0\n"
                                     "vt 0 0\nvt 1 0\nvt 1 1\n"
                                     "vn 0 0 1\n"
                                     "g side\ns off\nusemtl red\n"
                                     "f 1/1/1 2/2/1 3/3/1 4//1   # a quad\n"
                                     "v 0.5 0.5 1\n"
                                     "f -1 -5/2 -4\n"
                                     "l 1 2\n"
                                     "f 2/1 3 5\n");
  SurfaceMesh surface;
  std::string error;
  ASSERT_TRUE(ReadObj(path, &surface, &error)) << error;
  ASSERT_EQ(surface.num_vertices(), 5);
  EXPECT_EQ(surface.vertices.col(4), Eigen::Vector3d(0.5, 0.5, 1));
  ASSERT_EQ(surface.num_polygons(), 3);
  EXPECT_EQ(surface.face_offsets, (std::vector<int>{0, 4, 7, 10}));
  EXPECT_EQ(surface.face_vertices, (std::vector<int>{0, 1, 2, 3, 4, 0, 1, 1, 2, 4}));
  ASSERT_EQ(surface.num_triangles(), 4);
  EXPECT_EQ(surface.triangles.col(0), Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(surface.triangles.col(1), Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(surface.triangles.col(2), Eigen::Vector3i(4, 0, 1));
  EXPECT_EQ(surface.triangles.col(3), Eigen::Vector3i(1, 2, 4));
  EXPECT_EQ(surface.triangle_face, (std::vector<int>{0, 0, 1, 2}));
}

TEST(ObjReadTest, ForwardReferenceIsCheckedAtTheEnd) {
  testing::TempDir dir;
  const std::string path = dir.Write("fwd.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
  SurfaceMesh surface;
  std::string error;
  ASSERT_TRUE(ReadObj(path, &surface, &error)) << error;
  EXPECT_EQ(surface.triangles.col(0), Eigen::Vector3i(0, 1, 2));
  const std::string bad = ReadError("v 0 0 0\nf 1 2 3\nv 1 0 0\n");
  EXPECT_TRUE(Contains(bad,
                       "bad.obj:2: face vertex index 3 is out of range: the file has 2 "
                       "vertices"))
      << bad;
}

TEST(ObjReadTest, Malformed) {
  std::string error = ReadError("v 0 0 0\nv 1 0 0\n\nf 1 2\n");
  EXPECT_TRUE(Contains(error, "bad.obj:4: a face needs at least 3 corners, got 2")) << error;
  error = ReadError("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
  EXPECT_TRUE(Contains(error, "bad.obj:4: face corner '0': vertex index 0 is invalid")) << error;
  error = ReadError("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
  EXPECT_TRUE(Contains(error,
                       "bad.obj:4: face corner '-4': relative vertex index -4 is out of "
                       "range: only 3 vertices"))
      << error;
  error = ReadError("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/x/1 2 3\n");
  EXPECT_TRUE(Contains(error, "bad.obj:4: malformed face corner '1/x/1'")) << error;
  error = ReadError("v 0 0 0\nv 1 0 0\nv 0 1 0\nf a 2 3\n");
  EXPECT_TRUE(Contains(error, "bad.obj:4: expected a face corner")) << error;
  error = ReadError("v 0 0 0\nv 1 0 zero\n");
  EXPECT_TRUE(Contains(error,
                       "bad.obj:2: expected a finite number as entry 3 of the vertex "
                       "record, got 'zero'"))
      << error;
  error = ReadError("v 0 0\n");
  EXPECT_TRUE(Contains(error, "bad.obj:1: expected 'v x y z [w]'")) << error;
  // 5 numbers are neither x y z w nor x y z r g b.
  error = ReadError("v 0 0 0\nv 1 0 0 0.5 0.5\n");
  EXPECT_TRUE(Contains(error, "bad.obj:2: expected 'v x y z [w]'")) << error;
  EXPECT_TRUE(Contains(error, "got 5 numbers")) << error;
}

TEST(ObjWriteTest, PolygonsRoundTrip) {
  SurfaceMesh surface;
  surface.vertices.resize(3, 5);
  surface.vertices << 0, 1, 1, 0, 0.1,  //
      0, 0, 1, 1, 1.0 / 3.0,            //
      0, 0, 0, 0, -2e-17;
  surface.face_offsets = {0, 4, 7};
  surface.face_vertices = {0, 1, 2, 3, 4, 0, 1};
  surface.triangles.resize(3, 3);
  surface.triangles << 0, 0, 4, 1, 2, 0, 2, 3, 1;
  surface.triangle_face = {0, 0, 1};
  testing::TempDir dir;
  const std::string path = dir.File("out.obj");
  std::string error;
  ASSERT_TRUE(WriteObj(path, surface, &error)) << error;
  std::ifstream in(path);
  std::string first_line;
  std::getline(in, first_line);
  EXPECT_EQ(first_line, "# written by ActiveQS");
  SurfaceMesh read;
  ASSERT_TRUE(ReadObj(path, &read, &error)) << error;
  EXPECT_EQ(read.vertices, surface.vertices);
  EXPECT_EQ(read.face_offsets, surface.face_offsets);
  EXPECT_EQ(read.face_vertices, surface.face_vertices);
  EXPECT_EQ(read.triangles, surface.triangles);
  EXPECT_EQ(read.triangle_face, surface.triangle_face);
}

TEST(ObjWriteTest, TrianglesOnlySurface) {
  LatticeOptions options;
  options.nx = 2;
  const TetMesh mesh = MakeLatticeMesh(options);
  const SurfaceMesh surface = BoundaryToSurface(ExtractBoundarySurface(mesh), mesh.vertices);
  testing::TempDir dir;
  const std::string path = dir.File("boundary.obj");
  std::string error;
  ASSERT_TRUE(WriteObj(path, surface, &error)) << error;
  std::ifstream in(path);
  const std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(content.rfind("# written by ActiveQS\nv 0 0 0\nv 1 0 0\n", 0), 0u) << content;
  SurfaceMesh read;
  ASSERT_TRUE(ReadObj(path, &read, &error)) << error;
  EXPECT_EQ(read.vertices, surface.vertices);
  EXPECT_EQ(read.triangles, surface.triangles);
  EXPECT_EQ(read.num_polygons(), surface.num_triangles());
}

// A vertex with a non-finite coordinate is refused by the writers whose files the
// readers must read back (which refuse nan and inf), naming the file and the vertex, and
// nothing is written (before 2026-12-07 the OBJ, MEDIT and PLY writers wrote 'nan', and
// the file could not be read back).
TEST(ObjWriteTest, NonFiniteCoordinatesAreRefusedNamingTheVertex) {
  LatticeOptions options;
  options.nx = 2;
  TetMesh mesh = MakeLatticeMesh(options);
  mesh.vertices(2, 3) = std::numeric_limits<double>::quiet_NaN();
  SurfaceMesh surface = BoundaryToSurface(ExtractBoundarySurface(mesh), mesh.vertices);
  surface.vertices(0, 4) = std::numeric_limits<double>::infinity();
  testing::TempDir dir;
  std::string error;
  EXPECT_FALSE(WriteObj(dir.File("s.obj"), surface, &error));
  EXPECT_NE(error.find("s.obj: vertex 3 has a number that is not finite (nan)"),
            std::string::npos) << error;
  EXPECT_FALSE(std::ifstream(dir.File("s.obj")).good());
  EXPECT_FALSE(WriteMeditMesh(dir.File("m.mesh"), mesh, &error));
  EXPECT_NE(error.find("m.mesh: vertex 3 has a number that is not finite"), std::string::npos)
      << error;
  EXPECT_FALSE(std::ifstream(dir.File("m.mesh")).good());
  surface.vertices(2, 3) = 0.0;
  const std::vector<double> values(surface.num_vertices(), 1.0);
  EXPECT_FALSE(WritePlyWithScalar(dir.File("p.ply"), surface, values, 1.0, &error));
  EXPECT_NE(error.find("p.ply: vertex 4 has a number that is not finite (inf)"),
            std::string::npos) << error;
  EXPECT_FALSE(std::ifstream(dir.File("p.ply")).good());
}

}  // namespace
}  // namespace aqs
