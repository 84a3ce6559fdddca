// ReadMovingObstacles (contact/read_obstacles.h): obstacle specs read into the obstacles
// ContactSolver::Resolve takes, as aqs_collide reads --obstacles.

#include "contact/read_obstacles.h"

#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "mesh/mesh_io.h"
#include "testing/contact_scenes.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

// Two boxes in one file (as a file of teeth holds one shell per tooth) beside a model
// whose neutral is the unit cube's corners, with a bone "jaw".
class ReadObstaclesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Eigen::Matrix3Xd a, b;
    Eigen::Matrix3Xi ta, tb;
    testing::BoxSurface(Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0.4, -0.5, 1), &a, &ta);
    testing::BoxSurface(Eigen::Vector3d(0.6, -1, 0), Eigen::Vector3d(1, -0.5, 1), &b, &tb);
    SurfaceMesh both;
    both.vertices.resize(3, a.cols() + b.cols());
    both.vertices << a, b;
    both.triangles.resize(3, ta.cols() + tb.cols());
    both.triangles << ta, (tb.array() + static_cast<int>(a.cols())).matrix();
    std::string error;
    ASSERT_TRUE(WriteObj(dir_.File("teeth.obj"), both, &error)) << error;
    SurfaceMesh far = both;
    far.vertices.array() += 1e5;
    ASSERT_TRUE(WriteObj(dir_.File("far.obj"), far, &error)) << error;
    model_.neutral.vertices.resize(3, 8);
    for (int i = 0; i < 8; ++i) model_.neutral.vertices.col(i) << (i & 1), (i >> 1) & 1, i >> 2;
    Bone jaw;
    jaw.name = "jaw";
    model_.bones = {jaw};
  }

  testing::TempDir dir_;
  ActiveModel model_;
};

TEST_F(ReadObstaclesTest, SplitsFilesIntoShellsTiedToTheirBone) {
  const std::string teeth = dir_.File("teeth.obj");
  std::vector<MovingObstacle> obstacles;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(ReadMovingObstacles(teeth + " bone=jaw, " + teeth, model_, &obstacles, log, &error))
      << error;
  ASSERT_EQ(obstacles.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(obstacles[i].bone, i < 2 ? 0 : -1) << i;
    EXPECT_EQ(obstacles[i].triangles.cols(), 12) << i;
    EXPECT_EQ(obstacles[i].name, teeth + " shell " + std::to_string(i % 2 + 1));
  }
  EXPECT_EQ(log.str(), "obstacle " + teeth + ": 24 triangles in 2 shells, moving with jaw\n" +
                           "obstacle " + teeth + ": 24 triangles in 2 shells\n");
}

// A shell that is not closed is read with a warning naming it (an open patch gave no
// contact and no word); closed shells get none (the test above).
TEST_F(ReadObstaclesTest, AnOpenShellIsReadWithAWarning) {
  SurfaceMesh teeth;
  std::string error;
  ASSERT_TRUE(ReadObj(dir_.File("teeth.obj"), &teeth, &error)) << error;
  SurfaceMesh open;  // triangles only (no stored polygons), the 2nd box's last one left out
  open.vertices = teeth.vertices;
  open.triangles = teeth.triangles.leftCols(teeth.num_triangles() - 1);
  ASSERT_TRUE(WriteObj(dir_.File("open.obj"), open, &error)) << error;
  std::vector<MovingObstacle> obstacles;
  std::ostringstream log;
  ASSERT_TRUE(ReadMovingObstacles(dir_.File("open.obj"), model_, &obstacles, log, &error))
      << error;
  ASSERT_EQ(obstacles.size(), 2u);
  EXPECT_EQ(log.str(), "obstacle " + dir_.File("open.obj") + ": 23 triangles in 2 shells\n" +
                           "obstacle " + dir_.File("open.obj") + " shell 2: warning: not closed "
                           "(3 edges of one triangle only): contact pushes points out of what a "
                           "closed surface encloses, and points may pass through this one\n");
}

TEST_F(ReadObstaclesTest, AQuotedPathWithSpacesIsRead) {
  SurfaceMesh teeth;
  std::string error;
  ASSERT_TRUE(ReadObj(dir_.File("teeth.obj"), &teeth, &error)) << error;
  const std::string spaced = dir_.File("lower teeth, v2.obj");
  ASSERT_TRUE(WriteObj(spaced, teeth, &error)) << error;
  std::vector<MovingObstacle> obstacles;
  std::ostringstream log;
  ASSERT_TRUE(ReadMovingObstacles("\"" + spaced + "\" bone=jaw", model_, &obstacles, log, &error))
      << error;
  ASSERT_EQ(obstacles.size(), 2u);
  EXPECT_EQ(obstacles[0].bone, 0);
  EXPECT_EQ(obstacles[0].name, spaced + " shell 1");
}

TEST_F(ReadObstaclesTest, NamesTheItemOrFileOfEachError) {
  std::vector<MovingObstacle> obstacles;
  std::ostringstream log;
  std::string error;
  const std::string teeth = dir_.File("teeth.obj");
  EXPECT_FALSE(ReadMovingObstacles(teeth + " bone=skull", model_, &obstacles, log, &error));
  EXPECT_EQ(error, "obstacle " + teeth + ": the model has no bone 'skull'");
  EXPECT_FALSE(ReadMovingObstacles(dir_.File("far.obj"), model_, &obstacles, log, &error));
  EXPECT_NE(error.find(dir_.File("far.obj") + ": point 0"), std::string::npos) << error;
  EXPECT_FALSE(ReadMovingObstacles(dir_.File("none.obj"), model_, &obstacles, log, &error));
  EXPECT_NE(error.find(dir_.File("none.obj")), std::string::npos) << error;
  EXPECT_FALSE(ReadMovingObstacles(teeth + " colour=red", model_, &obstacles, log, &error));
  EXPECT_NE(error.find("colour"), std::string::npos) << error;
  SurfaceMesh points;
  points.vertices = model_.neutral.vertices;
  points.triangles.resize(3, 0);
  ASSERT_TRUE(WriteObj(dir_.File("points.obj"), points, &error)) << error;
  EXPECT_FALSE(ReadMovingObstacles(dir_.File("points.obj"), model_, &obstacles, log, &error));
  EXPECT_EQ(error, dir_.File("points.obj") +
                       ": has no faces (an obstacle is a closed surface of triangles)");
  EXPECT_TRUE(obstacles.empty());
}

// vertices=a:b keeps the triangles whose corners all lie in [a, b): of a strip of two
// triangles, (0 1 2) and (1 3 2), vertices=0:3 keeps the first only.
TEST_F(ReadObstaclesTest, AVertexRangeEndsBeforeItsEnd) {
  SurfaceMesh strip;
  strip.vertices.resize(3, 4);
  strip.vertices << 0, 1, 0, 1,  //
      0, 0, 1, 1,                //
      0, 0, 0, 0;
  strip.triangles.resize(3, 2);
  strip.triangles << 0, 1,  //
      1, 3,                 //
      2, 2;
  std::string error;
  ASSERT_TRUE(WriteObj(dir_.File("strip.obj"), strip, &error)) << error;
  std::vector<MovingObstacle> obstacles;
  std::ostringstream log;
  ASSERT_TRUE(ReadMovingObstacles(dir_.File("strip.obj") + " vertices=0:3", model_, &obstacles,
                                  log, &error))
      << error;
  ASSERT_EQ(obstacles.size(), 1u);
  EXPECT_EQ(obstacles[0].triangles.cols(), 1) << log.str();
}

}  // namespace
}  // namespace aqs
