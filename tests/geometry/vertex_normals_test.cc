#include "geometry/vertex_normals.h"

#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace aqs {
namespace {

// The corner tetrahedron (0, e_x, e_y, e_z), its faces counter-clockwise from outside,
// and a fifth vertex in no triangle.
void CornerTetrahedron(Eigen::Matrix3Xd* vertices, Eigen::Matrix3Xi* triangles) {
  vertices->resize(3, 5);
  *vertices << 0, 1, 0, 0, 7,
               0, 0, 1, 0, 7,
               0, 0, 0, 1, 7;
  triangles->resize(3, 4);
  *triangles << 0, 0, 0, 1,
                2, 1, 3, 2,
                1, 3, 2, 3;
}

// At the corner the three unit faces give -(1, 1, 1)/sqrt(3); at e_x the two unit faces
// (-e_y, -e_z, each twice area 1) and the slanted face (twice area sqrt(3) along
// (1, 1, 1)/sqrt(3)) sum to e_x: the weights are the areas. A vertex in no triangle: 0.
TEST(VertexNormalsTest, AreaWeightedUnitNormals) {
  Eigen::Matrix3Xd vertices;
  Eigen::Matrix3Xi triangles;
  CornerTetrahedron(&vertices, &triangles);
  const Eigen::Matrix3Xd normals = VertexNormals(vertices, triangles);
  EXPECT_LT((normals.col(0) + Eigen::Vector3d::Ones().normalized()).norm(), 1e-15);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_LT((normals.col(1 + axis) - Eigen::Vector3d::Unit(axis)).norm(), 1e-15) << axis;
  }
  EXPECT_EQ(normals.col(4), Eigen::Vector3d::Zero());
}

// Rotated, scaled and moved, the normals rotate with the surface.
TEST(VertexNormalsTest, FollowARigidMotionAndScaling) {
  Eigen::Matrix3Xd vertices;
  Eigen::Matrix3Xi triangles;
  CornerTetrahedron(&vertices, &triangles);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -1, 2).normalized()).toRotationMatrix();
  const Eigen::Matrix3Xd moved = ((2.5 * rotation) * vertices).colwise() + Eigen::Vector3d(4, 5, 6);
  const Eigen::Matrix3Xd expected = rotation * VertexNormals(vertices, triangles);
  const Eigen::Matrix3Xd normals = VertexNormals(moved, triangles);
  EXPECT_LT((normals.leftCols(4) - expected.leftCols(4)).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_EQ(normals.col(4), Eigen::Vector3d::Zero());
}

}  // namespace
}  // namespace aqs
