// The surface springs of prepare's attachments and of contact, against their formula.

#include "model/surface_springs.h"

#include <cmath>

#include <gtest/gtest.h>

#include "testing/synthetic_muscles.h"

namespace aqs {
namespace {

// k_i = relative x mean(mu) x A_i / h, each part recomputed here: A_i a third of the areas
// of the neutral triangles at vertex i (the mean area for a vertex in none), h the mean
// over elements of their six edges' mean length; with a stiffness that differs per
// element (with mu = 1 everywhere a dropped mean(mu) passes).
TEST(SurfaceSpringsTest, StiffnessIsAreaTimesRelativeStiffnessTimesMeanMuOverEdgeLength) {
  ActiveModel model = testing::MakeSyntheticMuscles(1, 0, 0.1, 3).model;
  for (Eigen::Index e = 0; e < model.mu.size(); ++e) model.mu[e] = 1.0 + 2.0 * (e % 3);
  // A vertex in no triangle.
  const Eigen::Index lone = model.neutral.vertices.cols();
  model.neutral.vertices.conservativeResize(3, lone + 1);
  model.neutral.vertices.col(lone) = Eigen::Vector3d(0.1, 0.2, 0.3);
  const Eigen::Index n = model.neutral.vertices.cols();
  Eigen::VectorXd area = Eigen::VectorXd::Zero(n);
  for (Eigen::Index t = 0; t < model.neutral.triangles.cols(); ++t) {
    const Eigen::Vector3d a = model.neutral.vertices.col(model.neutral.triangles(0, t));
    const Eigen::Vector3d b = model.neutral.vertices.col(model.neutral.triangles(1, t));
    const Eigen::Vector3d c = model.neutral.vertices.col(model.neutral.triangles(2, t));
    const double third = (b - a).cross(c - a).norm() / 6.0;
    for (int k = 0; k < 3; ++k) area[model.neutral.triangles(k, t)] += third;
  }
  ASSERT_EQ(area[lone], 0.0);
  area[lone] = area.sum() / static_cast<double>(n);
  double edge_sum = 0.0;
  const TetMesh& mesh = model.mesh;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    double element = 0.0;
    for (int i = 0; i < 4; ++i) {
      for (int j = i + 1; j < 4; ++j) {
        element += (mesh.vertices.col(mesh.tets(i, e)) - mesh.vertices.col(mesh.tets(j, e))).norm();
      }
    }
    edge_sum += element / 6.0;
  }
  const double h = edge_sum / mesh.num_tets();
  const double relative = 37.0;
  const Eigen::VectorXd expected = relative * model.mu.mean() / h * area;
  const Eigen::VectorXd k = SurfaceSpringStiffness(model, relative);
  ASSERT_EQ(k.size(), n);
  EXPECT_LT((k - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.maxCoeff());
  EXPECT_GT(model.mu.mean(), 2.0);
}

}  // namespace
}  // namespace aqs
