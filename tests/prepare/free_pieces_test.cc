// prepare/free_pieces.h: a free piece of the simulation mesh that no surface vertex is
// embedded in is removed, and everything that indexes elements or vertices follows the
// renumbering; one that surface vertices are embedded in is refused.

#include "prepare/free_pieces.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/test_meshes.h"

namespace aqs {
namespace {

// A lone element first (vertices 0..3, element 0), then the bar (4 x 2 x 2 cubes) with its
// left face static, a bone on its right face, and one surface point in each of three bar
// elements. The lone element has one static vertex and one vertex on the bone (not
// enough to hold it), so that both lists lose one.
struct PiecesScene {
  TetMesh bar;
  BoundaryConditions left;
  std::vector<int> right;
  ActiveModel model;
};

PiecesScene MakeScene() {
  PiecesScene scene;
  scene.bar = testing::BarMesh(4, 2, 2, 0.5);
  scene.left = testing::LeftFaceFixed(scene.bar);
  const double x_max = scene.bar.vertices.row(0).maxCoeff();
  for (int v = 0; v < scene.bar.num_vertices(); ++v) {
    if (scene.bar.vertices(0, v) > x_max - 1e-9) scene.right.push_back(v);
  }
  TetMesh lone = testing::UnitTet();  // edges of 0.2 from (5, 0, 0)
  lone.vertices = (0.2 * lone.vertices).colwise() + Eigen::Vector3d(5, 0, 0);
  ActiveModel& model = scene.model;
  model.mesh = testing::JoinMeshes(lone, scene.bar);
  model.mu = Eigen::VectorXd::LinSpaced(model.mesh.num_tets(), 1.0, 2.0);
  model.static_vertices = {1};
  for (int v : scene.left.vertices) model.static_vertices.push_back(v + 4);
  Bone bone;
  bone.name = "end";
  bone.vertices = {2};
  for (int v : scene.right) bone.vertices.push_back(v + 4);
  model.bones = {bone};
  model.embedding.element = {5, 1, 20};
  model.embedding.weights = Eigen::Matrix4Xd::Constant(4, 3, 0.25);
  model.embedding.offsets = Eigen::Matrix3Xd::Zero(3, 3);
  model.embedding.outside_distance = {0.0, 0.0, 0.0};
  return scene;
}

TEST(FreePiecesTest, ALonePieceWithoutSurfaceIsRemovedAndTheIndicesFollow) {
  PiecesScene scene = MakeScene();
  ActiveModel& model = scene.model;
  const Eigen::VectorXd mu = model.mu;
  FreePieceRemoval removal;
  std::string error;
  ASSERT_TRUE(RemoveFreePieces(&model, &removal, &error)) << error;
  EXPECT_EQ(removal.pieces, 1);
  EXPECT_EQ(removal.elements, 1);
  EXPECT_EQ(removal.vertices, 4);
  EXPECT_EQ(removal.first_element, 0);
  EXPECT_EQ(model.mesh.vertices, scene.bar.vertices);
  EXPECT_EQ(model.mesh.tets, scene.bar.tets);
  EXPECT_EQ(model.mu, mu.tail(scene.bar.num_tets()));
  EXPECT_EQ(model.embedding.element, (std::vector<int>{4, 0, 19}));
  EXPECT_EQ(model.static_vertices, scene.left.vertices);
  ASSERT_EQ(model.bones.size(), 1u);
  EXPECT_EQ(model.bones[0].vertices, scene.right);

  // Nothing more to remove: the model stays as it is.
  const ActiveModel again = model;
  ASSERT_TRUE(RemoveFreePieces(&model, &removal, &error)) << error;
  EXPECT_EQ(removal.pieces, 0);
  EXPECT_EQ(removal.first_element, -1);
  EXPECT_EQ(model.mesh.tets, again.mesh.tets);
  EXPECT_EQ(model.static_vertices, again.static_vertices);
}

TEST(FreePiecesTest, APieceWithSurfaceButNotHeldIsRefusedAndNothingChanges) {
  PiecesScene scene = MakeScene();
  ActiveModel& model = scene.model;
  model.embedding.element.push_back(0);  // a surface point in the lone element
  model.embedding.weights = Eigen::Matrix4Xd::Constant(4, 4, 0.25);
  model.embedding.offsets = Eigen::Matrix3Xd::Zero(3, 4);
  model.embedding.outside_distance.push_back(0.0);
  const TetMesh mesh = model.mesh;
  FreePieceRemoval removal;
  std::string error;
  EXPECT_FALSE(RemoveFreePieces(&model, &removal, &error));
  EXPECT_NE(error.find("element 0"), std::string::npos) << error;
  EXPECT_NE(error.find("1 surface vertices are embedded in it"), std::string::npos) << error;
  EXPECT_EQ(model.mesh.tets, mesh.tets);
  EXPECT_EQ(model.embedding.element.back(), 0);

  // Held by a third fixed vertex off the line of the other two: kept, with its surface.
  model.static_vertices.push_back(3);
  ASSERT_TRUE(RemoveFreePieces(&model, &removal, &error)) << error;
  EXPECT_EQ(removal.pieces, 0);
  EXPECT_EQ(model.mesh.num_tets(), 1 + scene.bar.num_tets());
}

}  // namespace
}  // namespace aqs
