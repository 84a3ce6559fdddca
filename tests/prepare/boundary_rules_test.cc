#include "prepare/boundary_rules.h"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mesh/mesh_io.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

// A bar of 6 x 1 x 1 unit cubes (vertices at x = 0..6), the vertices at x <= 5 fixed by a
// box; the bone drives those at x < 1.5 (x = 0 and 1, 8 vertices), the other 16 stay
// static, and the 4 at x = 6 are free.
class BoneClearanceTest : public ::testing::Test {
 protected:
  BoneClearanceTest() : mesh_(testing::BarMesh(6, 1, 1, 1.0)) {
    options_.fixed_boxes.emplace_back(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(5.5, 2, 2));
    BoneRule bone;
    bone.name = "jaw";
    bone.neutral_mesh = dir_.Write("bone.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    bone.region_boxes.emplace_back(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1.5, 2, 2));
    options_.bones.push_back(bone);
    options_.num_threads = 1;
  }

  // The static vertices' x coordinates after the rules, with the given clearance.
  std::vector<double> StaticX(double clearance) {
    options_.bone_clearance = clearance;
    std::string error, log;
    EXPECT_TRUE(options_.Validate(&error)) << error;
    ActiveModel model;
    EXPECT_TRUE(
        ApplyBoundaryRules(options_, mesh_, SurfaceMesh(), {"a"}, nullptr, &model, &log, &error))
        << error;
    EXPECT_EQ(model.bones.size(), 1u);
    EXPECT_EQ(model.bones[0].vertices.size(), 8u);
    std::vector<double> x;
    for (int v : model.static_vertices) x.push_back(mesh_.vertices(0, v));
    return x;
  }

  testing::TempDir dir_;
  TetMesh mesh_;
  BoundaryRuleOptions options_;
};

TEST_F(BoneClearanceTest, ZeroClearanceKeepsEveryStaticVertex) {
  EXPECT_EQ(StaticX(0.0).size(), 16u);
}

TEST_F(BoneClearanceTest, FreesExactlyTheStaticVerticesWithinTheClearance) {
  // Within 1 of a driven vertex: the x = 2 layer (4 vertices; x = 3 is 2 away).
  std::vector<double> x = StaticX(1.0);
  EXPECT_EQ(x.size(), 12u);
  for (double value : x) EXPECT_GE(value, 3.0);
  // Within 2: the x = 2 and x = 3 layers.
  x = StaticX(2.0);
  EXPECT_EQ(x.size(), 8u);
  for (double value : x) EXPECT_GE(value, 4.0);
  // Just below 1: nothing is that close but the driven vertices themselves.
  EXPECT_EQ(StaticX(0.999).size(), 16u);
}

// Vertices a bone drives are as fixed as static ones: a mesh whose every vertex is one
// or the other cannot move and is refused (it was written, and pretraining and training
// then ended "successfully" after failed evaluations). A clearance that frees some is
// accepted.
TEST_F(BoneClearanceTest, EveryVertexStaticOrDrivenIsRefused) {
  options_.fixed_boxes[0].max().x() = 7.0;
  std::string error, log;
  ActiveModel model;
  EXPECT_FALSE(
      ApplyBoundaryRules(options_, mesh_, SurfaceMesh(), {"a"}, nullptr, &model, &log, &error));
  EXPECT_EQ(error, "every simulation vertex (28) is fixed, at rest or driven by a bone: nothing "
                   "can move (check --fixed_depth, --fixed_box, --fixed_inside, --fixed_list, "
                   "--bone_region and --bone_clearance)");
  options_.bone_clearance = 1.0;
  EXPECT_TRUE(
      ApplyBoundaryRules(options_, mesh_, SurfaceMesh(), {"a"}, nullptr, &model, &log, &error))
      << error;
  EXPECT_EQ(model.static_vertices.size(), 16u);
}

// A pose whose name holds the pattern's key ("{pose}", which pose names may hold) gives
// its bone's pose file by one replacement (the replacement was searched again from the
// start and never ended).
TEST_F(BoneClearanceTest, APoseNamedWithThePatternsKeyIsReplacedOnce) {
  const std::string bone_pose = dir_.Write("wide{pose}.bone.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                                                  "f 1 2 3\n");
  options_.bones[0].pose_mesh_pattern = dir_.File("{pose}.bone.obj");
  std::string error, log;
  ActiveModel model;
  ASSERT_TRUE(ApplyBoundaryRules(options_, mesh_, SurfaceMesh(), {"wide{pose}"}, nullptr, &model,
                                 &log, &error))
      << error;
  ASSERT_EQ(model.bones.size(), 1u);
  EXPECT_TRUE(model.bones[0].pose_transforms[0].rotation.isIdentity(1e-12));
}

// A bone's pose surface with a vertex far away is refused by name (it made every other
// vertex's motion look like none, and the bone static in every pose); so is one where
// fewer than 3 vertices move, which no rigid transform is fitted to.
TEST_F(BoneClearanceTest, FarOrTooFewMovingBoneVerticesAreRefused) {
  options_.bones[0].pose_mesh_pattern = dir_.File("{pose}.bone.obj");
  dir_.Write("far.bone.obj", "v 0 0 0\nv 1 0 0\nv 0 1e10 0\nf 1 2 3\n");
  dir_.Write("one.bone.obj", "v 0 0 0\nv 1 0 0\nv 0 1.5 0\nf 1 2 3\n");
  std::string error, log;
  ActiveModel model;
  EXPECT_FALSE(
      ApplyBoundaryRules(options_, mesh_, SurfaceMesh(), {"far"}, nullptr, &model, &log, &error));
  EXPECT_NE(error.find("far.bone.obj: point 2 (0 1e+10 0) is"), std::string::npos) << error;
  EXPECT_FALSE(
      ApplyBoundaryRules(options_, mesh_, SurfaceMesh(), {"one"}, nullptr, &model, &log, &error));
  EXPECT_NE(error.find("bone 'jaw': only 1 of its vertices move"), std::string::npos) << error;
}

// Bone names are written as one field of bones.txt, where '#' starts a comment.
TEST_F(BoneClearanceTest, RejectsBoneNamesTheModelFilesCannotHold) {
  for (const std::string bad : {"jaw#1", "jaw 1", "jaw,1", ""}) {
    options_.bones[0].name = bad;
    std::string error;
    EXPECT_FALSE(options_.Validate(&error)) << bad;
    EXPECT_EQ(error.rfind("bones.name '" + bad + "' ", 0), 0u) << error;
  }
  options_.bones[0].name = "jaw_1.left-2";
  std::string error;
  EXPECT_TRUE(options_.Validate(&error)) << error;
}

TEST_F(BoneClearanceTest, RejectsANegativeOrNonFiniteClearance) {
  for (double bad : {-0.5, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()}) {
    options_.bone_clearance = bad;
    std::string error;
    EXPECT_FALSE(options_.Validate(&error));
    EXPECT_NE(error.find("bone_clearance"), std::string::npos) << error;
  }
}

// An empty bone surface is refused by name (the fit of its motion read past an empty
// vector and crashed).
TEST_F(BoneClearanceTest, AnEmptyBoneSurfaceIsRefused) {
  options_.bones[0].neutral_mesh = dir_.Write("empty.obj", "# nothing\n");
  std::string error, log;
  ActiveModel model;
  EXPECT_FALSE(
      ApplyBoundaryRules(options_, mesh_, SurfaceMesh(), {"a"}, nullptr, &model, &log, &error));
  EXPECT_NE(error.find("empty.obj: the bone 'jaw' at rest has no vertices"), std::string::npos)
      << error;
}

// --fixed_inside takes a closed surface either way oriented (an inward one fixed no
// vertex, silently), and one that holds no vertex is refused by name.
// Regions that overlap: a vertex in both goes to the first bone that lists it, only.
// The jaw (x < 1.5) first: it drives x = 0 and 1, the skull (x < 2.5) only x = 2, and 12
// static vertices stay (x = 3 to 5). The skull first: it takes x = 0 to 2, and the jaw's
// region holds no fixed vertex left for it.
TEST_F(BoneClearanceTest, OverlappingRegionsGiveAVertexToTheFirstBoneOnly) {
  BoneRule skull = options_.bones[0];
  skull.name = "skull";
  skull.region_boxes = {
      Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(2.5, 2, 2))};
  options_.bones.push_back(skull);
  std::string error, log;
  ActiveModel model;
  ASSERT_TRUE(
      ApplyBoundaryRules(options_, mesh_, SurfaceMesh(), {"a"}, nullptr, &model, &log, &error))
      << error;
  ASSERT_EQ(model.bones.size(), 2u);
  std::vector<int> drives(mesh_.num_vertices(), 0);
  for (const Bone& bone : model.bones) {
    for (int v : bone.vertices) ++drives[v];
  }
  for (int v = 0; v < mesh_.num_vertices(); ++v) EXPECT_LE(drives[v], 1) << "vertex " << v;
  for (int v : model.bones[0].vertices) EXPECT_LE(mesh_.vertices(0, v), 1.0);
  for (int v : model.bones[1].vertices) EXPECT_EQ(mesh_.vertices(0, v), 2.0);
  EXPECT_EQ(model.bones[0].vertices.size(), 8u);
  EXPECT_EQ(model.bones[1].vertices.size(), 4u);
  EXPECT_EQ(model.static_vertices.size(), 12u);

  std::swap(options_.bones[0], options_.bones[1]);
  EXPECT_FALSE(
      ApplyBoundaryRules(options_, mesh_, SurfaceMesh(), {"a"}, nullptr, &model, &log, &error));
  EXPECT_NE(error.find("bone 'jaw': no fixed vertex lies in its region"), std::string::npos)
      << error;
}

// --fixed_box, --keep_box and --bone_region's parser, by whole messages.
TEST(ParseBoxTest, ReadsSixNumbersAndRefusesMalformedBoxesNamingThem) {
  Eigen::AlignedBox3d box;
  std::string error;
  ASSERT_TRUE(ParseBox("-1,-1,-1,1,2,3", &box, &error)) << error;
  EXPECT_EQ(box.min(), Eigen::Vector3d(-1, -1, -1));
  EXPECT_EQ(box.max(), Eigen::Vector3d(1, 2, 3));
  const std::string below = "each minimum must be below its maximum";
  for (const char* text : {"0,0,0,0,1,1", "1,0,0,0,1,1", "0,0,2,1,1,1"}) {
    EXPECT_FALSE(ParseBox(text, &box, &error)) << text;
    EXPECT_EQ(error, "box '" + std::string(text) + "': " + below);
  }
  EXPECT_FALSE(ParseBox("0,0,0,1,1", &box, &error));
  EXPECT_EQ(error, "box '0,0,0,1,1': expected six numbers xmin,ymin,zmin,xmax,ymax,zmax");
  EXPECT_FALSE(ParseBox("0,0,0,1,1,1,1", &box, &error));
  EXPECT_EQ(error, "box '0,0,0,1,1,1,1': expected six numbers xmin,ymin,zmin,xmax,ymax,zmax");
  EXPECT_FALSE(ParseBox("0,0,0,1,1,x", &box, &error));
  EXPECT_EQ(error, "box '0,0,0,1,1,x': 'x' is not a number");
  for (const char* text : {"0,0,0,1,1,inf", "0,0,0,1,1,nan"}) {
    EXPECT_FALSE(ParseBox(text, &box, &error)) << text;
    EXPECT_NE(error.find("is not a number"), std::string::npos) << error;
  }
}

TEST(FixedInsideTest, EitherOrientationAndNoneInsideIsRefused) {
  testing::TempDir dir;
  const TetMesh mesh = testing::BarMesh(6, 1, 1, 1.0);
  // A box around the x = 0 and x = 1 layers, written outward and inward.
  const std::string corners = "v -0.5 -0.5 -0.5\nv 1.5 -0.5 -0.5\nv 1.5 1.5 -0.5\nv -0.5 1.5 -0.5\n"
                              "v -0.5 -0.5 1.5\nv 1.5 -0.5 1.5\nv 1.5 1.5 1.5\nv -0.5 1.5 1.5\n";
  const std::string outward = "f 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n"
                              "f 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
  const std::string inward = "f 1 3 4\nf 1 2 3\nf 5 7 6\nf 5 8 7\nf 1 6 2\nf 1 5 6\n"
                             "f 2 7 3\nf 2 6 7\nf 3 8 4\nf 3 7 8\nf 4 5 1\nf 4 8 5\n";
  for (const std::string& faces : {outward, inward}) {
    BoundaryRuleOptions options;
    options.num_threads = 1;
    options.fixed_inside_meshes = {dir.Write("box.obj", corners + faces)};
    std::string error, log;
    ActiveModel model;
    ASSERT_TRUE(
        ApplyBoundaryRules(options, mesh, SurfaceMesh(), {"a"}, nullptr, &model, &log, &error))
        << error;
    EXPECT_EQ(model.static_vertices.size(), 8u) << (faces == inward ? "inward" : "outward");
  }
  // --fixed_depth with the box as the neutral, either way oriented (inward, it fixed none,
  // and the error then asked for --fixed_depth).
  for (const std::string& faces : {outward, inward}) {
    SurfaceMesh neutral;
    std::string error, log;
    ASSERT_TRUE(ReadObj(dir.Write("neutral.obj", corners + faces), &neutral, &error)) << error;
    BoundaryRuleOptions options;
    options.num_threads = 1;
    options.fixed_depth = 0.3;  // the 8 vertices inside are 0.5 deep
    ActiveModel model;
    ASSERT_TRUE(ApplyBoundaryRules(options, mesh, neutral, {"a"}, nullptr, &model, &log, &error))
        << error << (faces == inward ? " (inward)" : " (outward)");
    EXPECT_EQ(model.static_vertices.size(), 8u) << (faces == inward ? "inward" : "outward");
  }
  // The same box 100 units away: nothing inside.
  std::string far;
  for (const char* line : {"v 99.5 99.5 99.5\nv 101.5 99.5 99.5\nv 101.5 101.5 99.5\n",
                           "v 99.5 101.5 99.5\nv 99.5 99.5 101.5\nv 101.5 99.5 101.5\n",
                           "v 101.5 101.5 101.5\nv 99.5 101.5 101.5\n"}) {
    far += line;
  }
  BoundaryRuleOptions options;
  options.num_threads = 1;
  options.fixed_boxes.emplace_back(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(0.5, 2, 2));
  options.fixed_inside_meshes = {dir.Write("far.obj", far + outward)};
  std::string error, log;
  ActiveModel model;
  EXPECT_FALSE(
      ApplyBoundaryRules(options, mesh, SurfaceMesh(), {"a"}, nullptr, &model, &log, &error));
  EXPECT_NE(error.find("far.obj: no simulation vertex lies inside it (--fixed_inside)"),
            std::string::npos)
      << error;
}

}  // namespace
}  // namespace aqs
