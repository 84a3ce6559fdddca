#include "io/vertex_list_io.h"

#include <gtest/gtest.h>

#include "testing/temp_dir.h"

namespace aqs {
namespace {

TEST(VertexListIoTest, FixedVerticesAtRestAndPrescribed) {
  testing::TempDir dir;
  Eigen::Matrix3Xd rest = Eigen::Matrix3Xd::Random(3, 5);
  const std::string path = dir.Write("fixed.txt", "# fixed\n3\n0 1.5 -2 0.25  # moved\n\n4\n");
  BoundaryConditions bc;
  std::string error;
  ASSERT_TRUE(ReadFixedVertices(path, rest, &bc, &error)) << error;
  EXPECT_EQ(bc.vertices, (std::vector<int>{3, 0, 4}));
  EXPECT_EQ(bc.positions.col(0), rest.col(3));
  EXPECT_EQ(bc.positions.col(1), Eigen::Vector3d(1.5, -2, 0.25));
  EXPECT_EQ(bc.positions.col(2), rest.col(4));
}

TEST(VertexListIoTest, MalformedFixedFilesNameTheLine) {
  testing::TempDir dir;
  const Eigen::Matrix3Xd rest = Eigen::Matrix3Xd::Zero(3, 5);
  BoundaryConditions bc;
  std::string error;
  EXPECT_FALSE(ReadFixedVertices(dir.Write("a.txt", "1\n5\n"), rest, &bc, &error));
  EXPECT_NE(error.find("a.txt:2: vertex index 5 is outside the mesh's range [0, 5)"),
            std::string::npos) << error;
  EXPECT_FALSE(ReadFixedVertices(dir.Write("b.txt", "1\n2\n1\n"), rest, &bc, &error));
  EXPECT_NE(error.find("b.txt:3: vertex 1 is listed again (first on line 1)"), std::string::npos)
      << error;
  EXPECT_FALSE(ReadFixedVertices(dir.Write("c.txt", "1 2\n"), rest, &bc, &error));
  EXPECT_NE(error.find("c.txt:1: expected 'index' or 'index x y z'"), std::string::npos) << error;
  EXPECT_FALSE(ReadFixedVertices(dir.Write("d.txt", "1.5\n"), rest, &bc, &error));
  EXPECT_NE(error.find("d.txt:1: expected a vertex index"), std::string::npos) << error;
  EXPECT_FALSE(ReadFixedVertices(dir.Write("e.txt", "-1\n"), rest, &bc, &error));
}

TEST(VertexListIoTest, PlainListRoundTrip) {
  testing::TempDir dir;
  std::string error;
  ASSERT_TRUE(WriteVertexList(dir.File("v.txt"), {4, 1, 7}, "three vertices", &error));
  std::vector<int> vertices;
  ASSERT_TRUE(ReadVertexList(dir.File("v.txt"), 8, &vertices, &error)) << error;
  EXPECT_EQ(vertices, (std::vector<int>{4, 1, 7}));
  EXPECT_FALSE(ReadVertexList(dir.File("v.txt"), 5, &vertices, &error));
}

}  // namespace
}  // namespace aqs
