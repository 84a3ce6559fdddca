#include "contact/self_contact_term.h"

#include <memory>
#include <random>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "geometry/distance/edge_sine.h"
#include "geometry/distance/triangle_quality.h"
#include "testing/contact_scenes.h"
#include "testing/energy_term_checks.h"
#include "testing/finite_difference.h"
#include "testing/gradient_check.h"

namespace aqs {
namespace {

using testing::DenseStiffness;
using testing::DifferencedHessian;
using testing::Stencil;

// A pair of the given kind with stiffness 5 whose four stencils (point, corners) lie over
// vertices 0..15, each over four consecutive ones, except that the last corner's fourth
// vertex is the point's first (a shared vertex: 15 unique ones).
SelfContactPair StencilledPair(SelfContactPair::Kind kind) {
  SelfContactPair pair;
  pair.kind = kind;
  pair.point = Stencil(0, Eigen::Vector4d(0.4, 0.3, 0.2, 0.1));
  pair.corner[0] = Stencil(4, Eigen::Vector4d(0.7, 0.1, 0.1, 0.1));
  pair.corner[1] = Stencil(8, Eigen::Vector4d(0.1, 0.7, 0.1, 0.1));
  pair.corner[2] = Stencil(12, Eigen::Vector4d(0.1, 0.1, 0.7, 0.1));
  pair.corner[2].vertex[3] = 0;
  pair.stiffness = 5.0;
  return pair;
}

// Checks one active self-contact pair (thickness 0.1, max depth 1, margin 0.05) at x
// (3 x 16, its stencils over vertices 0..15, one shared): a positive residual, its
// Jacobian against Ceres' GradientChecker, the energy gradient against central
// differences, and its stiffness against central differences of that gradient.
void CheckActiveSelfContactPair(const SelfContactPair& pair, const Eigen::Matrix3Xd& x) {
  const SelfContactTerm term({pair}, 0.1, 1.0, 0.05);
  std::vector<int> block_vertices;
  std::unique_ptr<ceres::CostFunction> cost(term.NewCostFunction(0, &block_vertices));
  EXPECT_EQ(block_vertices.size(), 15u);  // 16 slots, one shared
  std::vector<const double*> parameters;
  for (int v : block_vertices) parameters.push_back(x.col(v).data());
  double r = 0;
  ASSERT_TRUE(cost->Evaluate(parameters.data(), &r, nullptr));
  EXPECT_GT(r, 0.0);
  ceres::GradientChecker::ProbeResults results;
  testing::ProbeJacobians(*cost, parameters.data(), 1e-7, &results, testing::RiddersFrom(1e-4));
  EXPECT_LT(testing::MaxBlockError(results, 1e-10), 1e-6) << results.error_log;
  auto energy = [&](const Eigen::VectorXd& flat) {
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, 16);
    return term.AddEnergyAndGradient(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, 16), &g);
  };
  Eigen::Matrix3Xd gradient = Eigen::Matrix3Xd::Zero(3, 16);
  term.AddEnergyAndGradient(x, &gradient);
  const Eigen::Map<const Eigen::VectorXd> flat_gradient(gradient.data(), 48);
  EXPECT_LT(testing::RelativeError(
                flat_gradient, testing::CentralDifferenceGradient(
                                   energy, Eigen::Map<const Eigen::VectorXd>(x.data(), 48), 1e-6)),
            1e-7);
  // The stencils' elements (the pair's coupling joins them).
  Eigen::Matrix4Xi tets(4, 4);
  const PointStencil* stencils[4] = {&pair.point, &pair.corner[0], &pair.corner[1], &pair.corner[2]};
  for (int m = 0; m < 4; ++m) {
    for (int j = 0; j < 4; ++j) tets(j, m) = stencils[m]->vertex[j];
  }
  EXPECT_LT(testing::RelativeError(DenseStiffness(term, x, tets), DifferencedHessian(term, x)), 1e-6);
  // The projected stiffness (what contact Newton steps factor) is the Gauss-Newton part
  // alone: for one pair, E = r^2 / 2 and grad E = r dr, so it is grad grad^T / (2 E),
  // positive semi-definite.
  const double e = term.AddEnergyAndGradient(x, &gradient.setZero());
  const Eigen::MatrixXd projected = DenseStiffness(term, x, tets, StiffnessKind::kProjected);
  EXPECT_LT(testing::RelativeError(projected, flat_gradient * flat_gradient.transpose() / (2 * e)),
            1e-12);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(projected).eigenvalues().minCoeff(),
            -1e-12 * projected.norm());
}

TEST(SelfContactTermTest, ResidualJacobianAndEnergyGradient) {
  // A point just below a triangle above it (active), stencils over 16 vertices with a
  // shared one.
  SelfContactPair pair = StencilledPair(SelfContactPair::Kind::kPointTriangle);
  Eigen::Matrix3Xd x(3, 16);
  std::mt19937 rng(8);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (int v = 0; v < 16; ++v) {
    Eigen::Vector3d p;
    if (v < 4) p = Eigen::Vector3d(0.3, 0.3, -0.05);        // the point
    else if (v < 8) p = Eigen::Vector3d(0, 0, 0);           // corner a
    else if (v < 12) p = Eigen::Vector3d(1, 0, 0.05);       // corner b
    else p = Eigen::Vector3d(0, 1, -0.03);                  // corner c
    x.col(v) = p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  CheckActiveSelfContactPair(pair, x);
  // With an augmented-Lagrangian offset, a point in front of the plane by more than the
  // thickness (0.1) but less than thickness + offset is still pushed; without, it is not.
  Eigen::Matrix3Xd above = x;
  for (int v = 0; v < 4; ++v) above(2, v) += 0.2;
  Eigen::Matrix3Xd unused = Eigen::Matrix3Xd::Zero(3, 16);
  EXPECT_EQ(SelfContactTerm({pair}, 0.1, 1.0, 0.05).AddEnergyAndGradient(above, &unused), 0.0);
  pair.offset = 0.3;
  CheckActiveSelfContactPair(pair, above);
  // The same, rotated and moved (the plane distance is invariant).
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  CheckActiveSelfContactPair(pair, (rotation * above).colwise() + Eigen::Vector3d(0.7, -1.2, 2.0));
}

TEST(SelfContactTermTest, EdgeEdgeResidualJacobianAndEnergyGradient) {
  // Edge (p0, p1) along x just above edge (q0, q1) along y, over 16 vertices with one
  // shared; the pair keeps the first edge below (sign -1: the common normal e1 x e2
  // points up), so it is crossed (active).
  SelfContactPair pair = StencilledPair(SelfContactPair::Kind::kEdgeEdge);
  pair.sign = -1.0;
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 0.02);
  Eigen::Matrix3Xd x(3, 16);
  for (int v = 0; v < 16; ++v) {
    Eigen::Vector3d p;
    if (v < 4) p = Eigen::Vector3d(-0.5, 0.1, 0.02);
    else if (v < 8) p = Eigen::Vector3d(0.5, 0.0, 0.0);
    else if (v < 12) p = Eigen::Vector3d(0.1, -0.5, -0.03);
    else p = Eigen::Vector3d(-0.1, 0.5, -0.01);
    x.col(v) = p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  CheckActiveSelfContactPair(pair, x);
  // With sign +1 the pair keeps the first edge above: raised beyond the thickness, it
  // is not pushed.
  Eigen::Matrix3Xd unused = Eigen::Matrix3Xd::Zero(3, 16);
  SelfContactPair flipped = pair;
  flipped.sign = 1.0;
  Eigen::Matrix3Xd lifted = x;
  for (int v = 0; v < 8; ++v) lifted(2, v) += 0.3;
  EXPECT_EQ(SelfContactTerm({flipped}, 0.1, 1.0, 0.05).AddEnergyAndGradient(lifted, &unused), 0.0);
  // Crossed (first edge above), with an offset, rotated and moved; and near-parallel
  // edges (sine about 0.2).
  Eigen::Matrix3Xd raised = x;
  for (int v = 0; v < 8; ++v) raised(2, v) += 0.08;
  pair.offset = 0.2;
  CheckActiveSelfContactPair(pair, raised);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(-0.8, Eigen::Vector3d(0.6, 0.2, -0.7).normalized()).toRotationMatrix();
  CheckActiveSelfContactPair(pair, (rotation * raised).colwise() + Eigen::Vector3d(-0.3, 1.5, 0.4));
  Eigen::Matrix3Xd skew = x;
  for (int v = 8; v < 16; ++v) skew.col(v) = Eigen::Vector3d(x(1, v) * 0.2, x(1, v), x(2, v));
  for (int v = 8; v < 12; ++v) skew.col(v) = Eigen::Vector3d(-0.5, -0.1, -0.03);
  for (int v = 12; v < 16; ++v) skew.col(v) = Eigen::Vector3d(0.5, 0.1, -0.01);
  CheckActiveSelfContactPair(pair, skew);
  // Nearly parallel, within the fade band of the sine (weight below 1, with its
  // derivative).
  Eigen::Matrix3Xd fading(3, 16);
  for (int v = 0; v < 16; ++v) {
    const Eigen::Vector3d ends[4] = {{-0.5, 0.025, 0.02}, {0.5, -0.025, 0.0},
                                     {-0.5, -0.025, -0.03}, {0.5, 0.025, -0.01}};
    fading.col(v) = ends[v / 4] + 0.002 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  double sine = 0;
  ASSERT_TRUE(EdgeSine(pair.point.Position(fading), pair.corner[0].Position(fading),
                       pair.corner[1].Position(fading), pair.corner[2].Position(fading), &sine,
                       nullptr));
  EXPECT_GT(sine, kEdgeFadeSine + 0.01);
  EXPECT_LT(sine, kFullEdgeSine - 0.01);
  CheckActiveSelfContactPair(pair, fading);
  // Parallel edges: no energy.
  Eigen::Matrix3Xd parallel = fading;
  for (int v = 0; v < 16; ++v) parallel(1, v) = 0.0;
  EXPECT_EQ(SelfContactTerm({pair}, 0.1, 1.0, 0.05).AddEnergyAndGradient(parallel, &unused), 0.0);
}

TEST(SelfContactTermTest, PointTriangleFadesAsItsTriangleFlattens) {
  // A point below a squashed triangle (height h along y), whose quality lies inside the
  // fade band (weight below 1, with its derivatives through the corners), then flatter
  // (weight 0: no energy, however close the point).
  const SelfContactPair pair = StencilledPair(SelfContactPair::Kind::kPointTriangle);
  std::mt19937 rng(10);
  std::normal_distribution<double> noise(0.0, 2e-4);
  auto scene = [&](double h) {
    Eigen::Matrix3Xd x(3, 16);
    const Eigen::Vector3d at[4] = {{0.5, 0.3 * h, -0.002}, {0, 0, 0}, {1, 0, 0.001}, {0.5, h, 0}};
    for (int v = 0; v < 16; ++v) {
      x.col(v) = at[v / 4] + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    }
    return x;
  };
  auto quality_of = [&](const Eigen::Matrix3Xd& x) {
    double q = 0;
    EXPECT_TRUE(TriangleQuality(pair.corner[0].Position(x), pair.corner[1].Position(x),
                                pair.corner[2].Position(x), &q, nullptr));
    return q;
  };
  // q is about 4 h / 3 for this triangle.
  const Eigen::Matrix3Xd fading = scene(0.0112);
  EXPECT_GT(quality_of(fading), kTriangleFadeQuality + 0.002);
  EXPECT_LT(quality_of(fading), kFullTriangleQuality - 0.002);
  CheckActiveSelfContactPair(pair, fading);
  const Eigen::Matrix3Xd rotation =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(-0.2, 0.9, 0.4).normalized()).toRotationMatrix();
  CheckActiveSelfContactPair(pair, (rotation * fading).colwise() + Eigen::Vector3d(1.0, 0.2, -0.6));
  const Eigen::Matrix3Xd flat = scene(0.005);
  EXPECT_LT(quality_of(flat), kTriangleFadeQuality);
  Eigen::Matrix3Xd unused = Eigen::Matrix3Xd::Zero(3, 16);
  EXPECT_EQ(SelfContactTerm({pair}, 0.1, 1.0, 0.05).AddEnergyAndGradient(flat, &unused), 0.0);
}

}  // namespace
}  // namespace aqs
