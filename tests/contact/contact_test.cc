#include <limits>
#include <memory>
#include <random>
#include <string>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <Eigen/Geometry>
#include <glog/logging.h>
#include <gtest/gtest.h>

#include "contact/contact_solver.h"
#include "geometry/triangle_distance.h"
#include "contact/contact_terms.h"
#include "geometry/embedding.h"
#include "geometry/surface_tet_mesher.h"
#include "mesh/boundary_surface.h"
#include "mesh/lattice.h"
#include "sparse/stiffness_pattern.h"
#include "testing/finite_difference.h"
#include "testing/test_surfaces.h"

namespace aqs {
namespace {

// An axis-aligned box surface (closed, outward), as an obstacle.
void BoxSurface(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Eigen::Matrix3Xd* v,
                Eigen::Matrix3Xi* t) {
  LatticeOptions options;
  options.origin = lo;
  options.spacing = 1.0;
  TetMesh cube = MakeLatticeMesh(options);  // one unit cube
  for (int i = 0; i < cube.num_vertices(); ++i) {
    cube.vertices.col(i) = lo + (hi - lo).cwiseProduct(cube.vertices.col(i) - lo);
  }
  const BoundarySurface boundary = ExtractBoundarySurface(cube);
  *v = cube.vertices;
  *t = boundary.triangles;
}

double MaxBlockError(const ceres::GradientChecker::ProbeResults& r) {
  double worst = 0;
  for (size_t b = 0; b < r.jacobians.size(); ++b) {
    worst = std::max(worst, testing::RelativeError(r.jacobians[b], r.numeric_jacobians[b], 1e-10));
  }
  return worst;
}

TEST(PlaneDistanceTest, GradientMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd x(12);
    for (int i = 0; i < 12; ++i) x[i] = normal(rng);
    auto s_of = [](const Eigen::VectorXd& v) {
      double s = 0;
      PlaneDistance(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), &s,
                    nullptr, nullptr);
      return s;
    };
    double s = 0;
    Eigen::Matrix<double, 3, 4> g;
    Eigen::Vector3d beta;
    ASSERT_TRUE(PlaneDistance(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9), &s,
                              &g, &beta));
    const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(s_of, x, 1e-6);
    EXPECT_LT(testing::RelativeError(Eigen::Map<const Eigen::VectorXd>(g.data(), 12), numeric), 1e-8);
    // The projection is reproduced by the barycentric coordinates.
    const Eigen::Vector3d a = x.segment<3>(3), b = x.segment<3>(6), c = x.segment<3>(9);
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    EXPECT_LT((beta[0] * a + beta[1] * b + beta[2] * c - (x.segment<3>(0) - s * n)).norm(), 1e-10);
  }
}

TEST(EdgeDistanceTest, GradientAndClosestPointsMatch) {
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Eigen::VectorXd x(12);
    for (int i = 0; i < 12; ++i) x[i] = normal(rng);
    if (trial % 4 == 3) {
      // Nearly parallel edges (sine about 0.15).
      x.segment<3>(9) = x.segment<3>(6) + 1.3 * (x.segment<3>(3) - x.segment<3>(0)) +
                        0.2 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized() *
                            (x.segment<3>(3) - x.segment<3>(0)).norm();
    }
    auto s_of = [](const Eigen::VectorXd& v) {
      double s = 0;
      CHECK(EdgeDistance(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), 0.0,
                         &s, nullptr, nullptr, nullptr));
      return s;
    };
    double s = 0, u = 0, w = 0;
    Eigen::Matrix<double, 3, 4> g;
    if (!EdgeDistance(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9),
                      kEdgeFadeSine, &s, &g, &u, &w)) {
      continue;
    }
    ++checked;
    const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(s_of, x, 1e-6);
    EXPECT_LT(testing::RelativeError(Eigen::Map<const Eigen::VectorXd>(g.data(), 12), numeric), 1e-7)
        << "trial " << trial;
    // The closest points are |s| apart, along the common normal.
    const Eigen::Vector3d p = x.segment<3>(0) + u * (x.segment<3>(3) - x.segment<3>(0));
    const Eigen::Vector3d q = x.segment<3>(6) + w * (x.segment<3>(9) - x.segment<3>(6));
    EXPECT_NEAR((p - q).norm(), std::abs(s), 1e-9);
    EXPECT_LT(std::abs((p - q).dot(x.segment<3>(3) - x.segment<3>(0))), 1e-9);
    EXPECT_LT(std::abs((p - q).dot(x.segment<3>(9) - x.segment<3>(6))), 1e-9);
  }
  EXPECT_GE(checked, 30);
  // The sine's gradient, at the same kinds of states.
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd x(12);
    for (int i = 0; i < 12; ++i) x[i] = normal(rng);
    if (trial % 2 == 1) {
      x.segment<3>(9) = x.segment<3>(6) + 0.8 * (x.segment<3>(3) - x.segment<3>(0)) +
                        0.1 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    }
    auto sine_of = [](const Eigen::VectorXd& v) {
      double sine = 0;
      CHECK(EdgeSine(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), &sine,
                     nullptr));
      return sine;
    };
    double sine = 0;
    Eigen::Matrix<double, 3, 4> g;
    ASSERT_TRUE(EdgeSine(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9), &sine,
                         &g));
    const Eigen::Vector3d e1 = x.segment<3>(3) - x.segment<3>(0), e2 = x.segment<3>(9) - x.segment<3>(6);
    EXPECT_NEAR(sine, e1.cross(e2).norm() / (e1.norm() * e2.norm()), 1e-14);
    EXPECT_LT(testing::RelativeError(Eigen::Map<const Eigen::VectorXd>(g.data(), 12),
                                     testing::CentralDifferenceGradient(sine_of, x, 1e-6)),
              1e-7)
        << "trial " << trial << " sine " << sine;
    // And its Hessian, against differences of that gradient.
    auto sine_gradient = [](const Eigen::VectorXd& v) {
      double sine = 0;
      Eigen::Matrix<double, 3, 4> gradient;
      CHECK(EdgeSine(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), &sine,
                     &gradient));
      return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(gradient.data(), 12));
    };
    Eigen::Matrix<double, 12, 12> hessian;
    ASSERT_TRUE(EdgeSineHessian(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9),
                                &hessian));
    EXPECT_LT(testing::RelativeError(hessian, testing::CentralDifferenceJacobian(sine_gradient, x, 1e-5)),
              1e-6)
        << "trial " << trial << " sine " << sine;
  }
  // Parallel edges are refused.
  double s = 0;
  EXPECT_FALSE(EdgeDistance(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                            Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(2, 1.01, 0), kMinEdgeSine, &s,
                            nullptr, nullptr, nullptr));
}

// A single-tet "mesh" whose vertices carry a point stencil, for term tests.
TEST(SelfContactDistanceTest, HessianMatchesFiniteDifferences) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 1.0);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(2.3, Eigen::Vector3d(-0.2, 0.9, 0.4).normalized()).toRotationMatrix();
  for (const SelfContactPair::Kind kind :
       {SelfContactPair::Kind::kPointTriangle, SelfContactPair::Kind::kEdgeEdge}) {
    SelfContactPair pair;
    pair.kind = kind;
    pair.sign = kind == SelfContactPair::Kind::kEdgeEdge ? -1.0 : 1.0;
    // Random states; rotated; near-degenerate (a thin triangle, nearly parallel edges).
    std::vector<Eigen::Matrix<double, 3, 4>> states;
    for (int trial = 0; trial < 4; ++trial) {
      Eigen::Matrix<double, 3, 4> points;
      for (int k = 0; k < 12; ++k) points(k) = noise(rng);
      states.push_back(points);
      states.push_back(rotation * points);
    }
    Eigen::Matrix<double, 3, 4> thin;
    if (kind == SelfContactPair::Kind::kPointTriangle) {
      thin << 0.3, 0, 1, 0.5, 0.2, 0, 0, 0.02, 0.4, 0, 0.01, 0;  // corners nearly collinear
    } else {
      thin << 0, 1, 0.1, 1.1, 0, 0.02, 0.1, 0.1 - 0.02, 0, 0.01, -0.3, -0.3;  // sine ~0.04
    }
    states.push_back(thin);
    for (const Eigen::Matrix<double, 3, 4>& state : states) {
      const Eigen::Vector3d points[4] = {state.col(0), state.col(1), state.col(2), state.col(3)};
      Eigen::Matrix<double, 12, 12> hessian;
      ASSERT_TRUE(SelfContactDistanceHessian(pair, points, &hessian));
      auto gradient = [&](const Eigen::VectorXd& flat) {
        const Eigen::Vector3d p[4] = {flat.segment<3>(0), flat.segment<3>(3), flat.segment<3>(6),
                                      flat.segment<3>(9)};
        double s = 0, outside = 0;
        Eigen::Matrix<double, 3, 4> g;
        CHECK(SelfContactDistance(pair, p, &s, &g, &outside));
        return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(g.data(), 12));
      };
      const Eigen::MatrixXd differenced = testing::CentralDifferenceJacobian(
          gradient, Eigen::Map<const Eigen::VectorXd>(state.data(), 12), 1e-5);
      EXPECT_LT(testing::RelativeError(hessian, differenced), 1e-6)
          << (kind == SelfContactPair::Kind::kEdgeEdge ? "edge-edge" : "point-triangle") << "\n"
          << state;
      EXPECT_LT((hessian - hessian.transpose()).norm(), 1e-12 * hessian.norm());
    }
  }
}

PointStencil Stencil(int first, const Eigen::Vector4d& w) {
  PointStencil s;
  for (int j = 0; j < 4; ++j) {
    s.vertex[j] = first + j;
    s.weight[j] = w[j];
  }
  s.offset = Eigen::Vector3d(0.01, -0.02, 0.03);
  return s;
}

// A term's stiffness at x (3 x n, all vertices free) as a dense 3n x 3n matrix, on the
// pattern of the given elements plus the term's couplings.
Eigen::MatrixXd DenseStiffness(const EnergyTerm& term, const Eigen::Matrix3Xd& x,
                               const Eigen::Matrix4Xi& tets) {
  const int n = static_cast<int>(x.cols());
  std::vector<std::vector<int>> couplings;
  term.AppendVertexCouplings(&couplings);
  const StiffnessPattern pattern(tets, std::vector<bool>(n, false), couplings);
  std::vector<double> values(pattern.num_nonzeros(), 0.0);
  term.AddStiffness(x, pattern, StiffnessKind::kExact, &values);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (int j = 0; j < pattern.num_dofs(); ++j) {
    for (int64_t k = pattern.column_starts()[j]; k < pattern.column_starts()[j + 1]; ++k) {
      const int64_t i = pattern.row_indices()[k];
      dense(i, j) = dense(j, i) = values[k];
    }
  }
  return dense;
}

// Central differences of a term's energy gradient at x (3 x n): its Hessian, 3n x 3n.
Eigen::MatrixXd DifferencedHessian(const EnergyTerm& term, const Eigen::Matrix3Xd& x) {
  const int n = static_cast<int>(x.cols());
  auto gradient = [&](const Eigen::VectorXd& flat) {
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, n);
    term.AddEnergyAndGradient(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, n), &g);
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(g.data(), 3 * n));
  };
  return testing::CentralDifferenceJacobian(
      gradient, Eigen::Map<const Eigen::VectorXd>(x.data(), 3 * n), 1e-6);
}

TEST(ObstacleContactTermTest, ResidualJacobianAndEnergyGradient) {
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  BoxSurface(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 1, 1), &v, &t);
  const Obstacle box("box", v, t);
  // A point inside the box (penetrating) and one just outside within the thickness.
  const std::vector<PointStencil> points = {Stencil(0, Eigen::Vector4d(0.1, 0.2, 0.3, 0.4)),
                                            Stencil(4, Eigen::Vector4d(0.25, 0.25, 0.25, 0.25))};
  const ObstacleContactTerm term(points, Eigen::Vector2d(3.0, 2.0), 0.1, {&box});
  Eigen::Matrix3Xd x(3, 8);
  x << 0.5, 0.6, 0.4, 0.5, 1.0, 1.1, 1.0, 0.9,  //
      0.8, 0.9, 0.7, 0.85, 1.02, 1.06, 1.04, 1.05,  //
      0.4, 0.5, 0.6, 0.3, 0.5, 0.4, 0.6, 0.5;
  for (int i = 0; i < 2; ++i) {
    std::unique_ptr<ceres::CostFunction> cost(term.NewCostFunction(i));
    const double* parameters[4];
    for (int j = 0; j < 4; ++j) parameters[j] = x.col(points[i].vertex[j]).data();
    double r = 0;
    ASSERT_TRUE(cost->Evaluate(parameters, &r, nullptr));
    EXPECT_GT(r, 0.0) << "point " << i << " is in contact";
    ceres::NumericDiffOptions numeric;
    numeric.ridders_relative_initial_step_size = 1e-4;
    const std::vector<const ceres::Manifold*>* none = nullptr;
    ceres::GradientChecker checker(cost.get(), none, numeric);
    ceres::GradientChecker::ProbeResults results;
    checker.Probe(parameters, 1e-7, &results);
    EXPECT_LT(MaxBlockError(results), 1e-6) << results.error_log;
  }
  auto energy = [&](const Eigen::VectorXd& flat) {
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, 8);
    return term.AddEnergyAndGradient(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, 8), &g);
  };
  Eigen::Matrix3Xd gradient = Eigen::Matrix3Xd::Zero(3, 8);
  term.AddEnergyAndGradient(x, &gradient);
  EXPECT_LT(testing::RelativeError(
                Eigen::Map<const Eigen::VectorXd>(gradient.data(), 24),
                testing::CentralDifferenceGradient(
                    energy, Eigen::Map<const Eigen::VectorXd>(x.data(), 24), 1e-6)),
            1e-7);
  // The stiffness (Gauss-Newton part, exact here: both closest features are faces).
  Eigen::Matrix4Xi tets(4, 2);
  tets << 0, 4, 1, 5, 2, 6, 3, 7;
  EXPECT_LT(testing::RelativeError(DenseStiffness(term, x, tets), DifferencedHessian(term, x)),
            1e-6);
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
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-4;
  const std::vector<const ceres::Manifold*>* none = nullptr;
  ceres::GradientChecker checker(cost.get(), none, numeric);
  ceres::GradientChecker::ProbeResults results;
  checker.Probe(parameters.data(), 1e-7, &results);
  EXPECT_LT(MaxBlockError(results), 1e-6) << results.error_log;
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
}

TEST(SelfContactTermTest, ResidualJacobianAndEnergyGradient) {
  // A point just below a triangle above it (active), stencils over 16 vertices with a
  // shared one.
  SelfContactPair pair;
  pair.point = Stencil(0, Eigen::Vector4d(0.4, 0.3, 0.2, 0.1));
  pair.corner[0] = Stencil(4, Eigen::Vector4d(0.7, 0.1, 0.1, 0.1));
  pair.corner[1] = Stencil(8, Eigen::Vector4d(0.1, 0.7, 0.1, 0.1));
  pair.corner[2] = Stencil(12, Eigen::Vector4d(0.1, 0.1, 0.7, 0.1));
  pair.corner[2].vertex[3] = 0;  // shares a vertex with the point
  pair.stiffness = 5.0;
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
  SelfContactPair pair;
  pair.kind = SelfContactPair::Kind::kEdgeEdge;
  pair.point = Stencil(0, Eigen::Vector4d(0.4, 0.3, 0.2, 0.1));
  pair.corner[0] = Stencil(4, Eigen::Vector4d(0.7, 0.1, 0.1, 0.1));
  pair.corner[1] = Stencil(8, Eigen::Vector4d(0.1, 0.7, 0.1, 0.1));
  pair.corner[2] = Stencil(12, Eigen::Vector4d(0.1, 0.1, 0.7, 0.1));
  pair.corner[2].vertex[3] = 0;
  pair.stiffness = 5.0;
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

// A model of lattice blocks with the given boundary conditions, its surface the mesh
// boundary (no training data: only what ContactSolver needs).
ActiveModel BlockModel(const TetMesh& mesh, const std::vector<int>& fixed) {
  ActiveModel model;
  model.mesh = mesh;
  model.mu = Eigen::VectorXd::Ones(mesh.num_tets());
  model.static_vertices = fixed;
  const BoundarySurface boundary = ExtractBoundarySurface(mesh);
  model.neutral.vertices = mesh.vertices;  // all vertices; only boundary ones are in triangles
  model.neutral.triangles = boundary.triangles;
  model.embedding = EmbedPoints(mesh, mesh.vertices, 1);
  return model;
}

// The equilibrium of a one-bone model at rest actuation with the bone moved by `push`
// (3 x num_vertices), without contact; false if it does not converge.
bool ContactFreeEquilibrium(const ActiveModel& model, const RigidTransform& push,
                            Eigen::Matrix3Xd* positions) {
  const ShapeTargetModel physics(model.mesh, model.mu);
  QuasistaticSolver solver(physics, ModelBoundaryConditions(model, {push}));
  const bool converged = solver.Solve().converged;
  *positions = solver.positions();
  return converged;
}

TEST(ContactSolverTest, BlockPushedIntoASlabStopsAtItsSurface) {
  LatticeOptions lattice;
  lattice.nx = 3;
  lattice.ny = 3;
  lattice.nz = 3;
  lattice.spacing = 1.0 / 3.0;
  lattice.type = LatticeType::kKuhn;
  const TetMesh block = MakeLatticeMesh(lattice);  // [0, 1]^3
  std::vector<int> top;
  for (int v = 0; v < block.num_vertices(); ++v) {
    if (block.vertices(1, v) > 1 - 1e-9) top.push_back(v);
  }
  ActiveModel model = BlockModel(block, top);
  // Push the top down by 0.4: the block's bottom would reach y = -0.4 inside the slab
  // below y = -0.2.
  Bone lid;
  lid.name = "lid";
  lid.vertices = top;
  model.static_vertices.clear();
  model.bones = {lid};
  RigidTransform push;
  push.translation = Eigen::Vector3d(0, -0.4, 0);
  Eigen::Matrix3Xd free;
  ASSERT_TRUE(ContactFreeEquilibrium(model, push, &free));
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  BoxSurface(Eigen::Vector3d(-1, -2, -1), Eigen::Vector3d(2, -0.2, 2), &v, &t);
  MovingObstacle slab;
  slab.name = "slab";
  slab.vertices = v;
  slab.triangles = t;
  ContactOptions options;
  options.thickness = 0.02;
  options.relative_stiffness = 1000.0;
  options.self_contact = false;
  options.solver.relative_force_tolerance = 1e-8;
  ContactSolver solver(model, options);
  Eigen::Matrix3Xd state;
  ContactReport report;
  std::string error;
  ASSERT_TRUE(solver.Resolve(IdentityActuations(block.num_tets()), {push}, {slab},
                             free, &state, &report, &error))
      << error;
  EXPECT_GT(report.max_penetration_before, 0.15) << report.Summary();
  EXPECT_GT(report.penetrating_points_before, 0);
  EXPECT_EQ(report.penetrating_points_after, 0) << report.Summary();
  EXPECT_EQ(report.obstacle_intersections_after, 0) << report.Summary();
  // The bottom rests on the slab, within the contact thickness.
  const double lowest = state.row(1).minCoeff();
  EXPECT_GE(lowest, -0.2 - 1e-9);
  EXPECT_LE(lowest, -0.2 + options.thickness);
  EXPECT_GT(report.obstacle_contacts, 0);
}

TEST(ContactSolverTest, CountsNewSelfIntersectionsByTheirRestState) {
  // A unit block whose embedded surface is five loose triangles: A (horizontal) and B
  // (vertical) crossing each other at rest, C and D apart from everything, E 0.01 above
  // D (touching it, within rest_tolerance).
  LatticeOptions lattice;
  lattice.nx = lattice.ny = lattice.nz = 2;
  lattice.spacing = 0.5;
  ActiveModel model = BlockModel(MakeLatticeMesh(lattice), {0});
  Eigen::Matrix3Xd rest(3, 15);
  rest << 0.2, 0.8, 0.5, 0.5, 0.5, 0.5, 0.1, 0.3, 0.2, 0.7, 0.9, 0.8, 0.7, 0.9, 0.8,  //
          0.2, 0.2, 0.8, 0.4, 0.6, 0.5, 0.1, 0.1, 0.3, 0.1, 0.1, 0.3, 0.1, 0.1, 0.3,  //
          0.5, 0.5, 0.5, 0.3, 0.3, 0.7, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9, 0.91, 0.91, 0.91;
  model.neutral.vertices = rest;
  model.neutral.triangles.resize(3, 5);
  model.neutral.triangles << 0, 3, 6, 9, 12, 1, 4, 7, 10, 13, 2, 5, 8, 11, 14;
  model.embedding = EmbedPoints(model.mesh, rest, 1);
  ContactOptions options;
  options.exclusion_rings = 0;
  const ContactSolver solver(model, options);
  // The counts at a state, against all / new / separated / clean.
  auto expect_counts = [&](const Eigen::Matrix3Xd& state, const std::string& what, int all,
                           int new_pairs, int separated, int clean) {
    const SelfIntersectionCounts counts = solver.CountSelfIntersections(state);
    EXPECT_EQ(counts.all, all) << what;
    EXPECT_EQ(counts.new_pairs, new_pairs) << what;
    EXPECT_EQ(counts.separated, separated) << what;
    EXPECT_EQ(counts.clean, clean) << what;
  };
  expect_counts(rest, "at rest", 1, 0, 0, 0);
  // C moved through A (which intersects B at rest): new and apart at rest, not clean.
  Eigen::Matrix3Xd c_through_a = rest;
  c_through_a.middleCols(6, 3) << 0.3, 0.4, 0.35, 0.3, 0.3, 0.3, 0.4, 0.4, 0.6;
  expect_counts(c_through_a, "C through A", 2, 1, 1, 0);
  // D moved through C (both clean at rest): new, apart at rest and clean.
  Eigen::Matrix3Xd d_through_c = rest;
  d_through_c.middleCols(9, 3) << 0.2, 0.25, 0.15, 0.2, 0.2, 0.2, 0.85, 0.95, 0.95;
  expect_counts(d_through_c, "D through C", 2, 1, 1, 1);
  // E turned through D, which it touched at rest: new and clean, not separated.
  Eigen::Matrix3Xd e_through_d = rest;
  e_through_d.middleCols(12, 3) << 0.8, 0.85, 0.75, 0.2, 0.2, 0.2, 0.85, 0.95, 0.95;
  expect_counts(e_through_d, "E through D", 2, 1, 0, 1);
}

// Two soft balls, each a lattice under a smooth embedded sphere (as faces are modelled),
// in one model whose surface is both spheres (radius 0.5, centres 1.1 apart): the left
// ball held at its far side, the right one driven by its far side (bone "driver").
ActiveModel TwoBallsModel(int* surface_vertices_per_ball) {
  const SurfaceMesh left_sphere = testing::Icosphere(3, 0.5, Eigen::Vector3d(0, 0, 0));
  const SurfaceMesh right_sphere = testing::Icosphere(3, 0.5, Eigen::Vector3d(1.1, 0, 0));
  SurfaceTetMeshOptions meshing;
  meshing.spacing = 0.2;
  TetMesh left_mesh, right_mesh;
  std::string error;
  CHECK(MeshSurfaceInterior(left_sphere.vertices, left_sphere.triangles, meshing, &left_mesh,
                            &error)) << error;
  CHECK(MeshSurfaceInterior(right_sphere.vertices, right_sphere.triangles, meshing, &right_mesh,
                            &error)) << error;
  ActiveModel model;
  model.mesh.vertices.resize(3, left_mesh.num_vertices() + right_mesh.num_vertices());
  model.mesh.vertices << left_mesh.vertices, right_mesh.vertices;
  model.mesh.tets.resize(4, left_mesh.num_tets() + right_mesh.num_tets());
  model.mesh.tets << left_mesh.tets, (right_mesh.tets.array() + left_mesh.num_vertices()).matrix();
  model.mu = Eigen::VectorXd::Ones(model.mesh.num_tets());
  const int ns = left_sphere.num_vertices();
  model.neutral.vertices.resize(3, 2 * ns);
  model.neutral.vertices << left_sphere.vertices, right_sphere.vertices;
  model.neutral.triangles.resize(3, 2 * left_sphere.num_triangles());
  model.neutral.triangles << left_sphere.triangles, (right_sphere.triangles.array() + ns).matrix();
  model.embedding = EmbedPoints(model.mesh, model.neutral.vertices, 2);
  Bone driver;
  driver.name = "driver";
  for (int v = 0; v < model.mesh.num_vertices(); ++v) {
    if (model.mesh.vertices(0, v) < -0.3) model.static_vertices.push_back(v);
    if (model.mesh.vertices(0, v) > 1.4) driver.vertices.push_back(v);
  }
  model.bones = {driver};
  *surface_vertices_per_ball = ns;
  return model;
}

// Contact options of the two-balls tests: thickness 0.01, search radius 0.1.
ContactOptions BallsContactOptions(double max_depth) {
  ContactOptions options;
  options.thickness = 0.01;
  options.search_radius = 0.1;
  options.max_depth = max_depth;
  return options;
}

// Along the centre line of TwoBallsModel at `state`: the right ball's leftmost surface
// point minus the left ball's rightmost one (negative: they overlap).
double BallsGap(const ActiveModel& model, int surface_vertices_per_ball,
                const Eigen::Matrix3Xd& state) {
  const int ns = surface_vertices_per_ball;
  const Eigen::Matrix3Xd surface = EmbeddedPositions(model.embedding, model.mesh.tets, state);
  return surface.rightCols(ns).row(0).minCoeff() - surface.leftCols(ns).row(0).maxCoeff();
}

// The right ball of TwoBallsModel pushed `distance` towards the left one (its bone's
// motion into *push) and the contact-free equilibrium there (*free); false if that does
// not converge.
bool PushBalls(const ActiveModel& model, double distance, RigidTransform* push,
               Eigen::Matrix3Xd* free) {
  push->translation = Eigen::Vector3d(-distance, 0, 0);
  return ContactFreeEquilibrium(model, *push, free);
}

TEST(ContactSolverTest, TwoSpheresPressedTogetherFlattenWithoutIntersecting) {
  // The right ball pushed 0.3 towards the left one (0.1 gap: 0.2 of overlap without
  // contact).
  int ns = 0;
  const ActiveModel model = TwoBallsModel(&ns);
  RigidTransform push;
  Eigen::Matrix3Xd free;
  ASSERT_TRUE(PushBalls(model, 0.3, &push, &free));
  ContactOptions options = BallsContactOptions(0.4);
  for (int path_steps : {0, 8}) {
    options.path_steps = path_steps;
    ContactSolver solver(model, options);
    Eigen::Matrix3Xd state;
    ContactReport report;
    std::string error;
    ASSERT_TRUE(solver.Resolve(IdentityActuations(model.mesh.num_tets()), {push}, {},
                               free, &state, &report, &error))
        << error;
    EXPECT_GT(report.self_intersections_before, 50) << report.Summary();
    EXPECT_EQ(report.self_intersections_after, 0) << report.Summary();
    EXPECT_GT(report.self_contacts, 0) << report.Summary();
    EXPECT_TRUE(report.converged) << report.Summary();
    EXPECT_EQ(report.path_steps, path_steps) << report.Summary();
    // The spheres meet flattened: along the centre line, the right sphere's leftmost
    // point is within the thickness of the left sphere's rightmost one, not behind it.
    const double gap = BallsGap(model, ns, state);
    EXPECT_GE(gap, -0.01) << report.Summary();
    EXPECT_LE(gap, 3 * options.thickness) << report.Summary();
    // The far sides stay where they were held.
    EXPECT_LT(report.max_far_displacement, 0.05) << report.Summary();
  }
}

TEST(ContactSolverTest, NewtonStepsOnTheContactStiffnessReachTheTolerance) {
  // The two balls pressed together (as above), with the self-contact pairs detected at
  // the contact-free equilibrium and offsets as the augmented Lagrangian makes them
  // (large residuals: Gauss-Newton converges linearly there). One equilibrium solve
  // with those pairs fixed, with Newton steps on the stiffness with the pairs' Hessians
  // (their couplings in the pattern) and with Levenberg-Marquardt only. (Pairs switching
  // on and off make the first Newton steps short; once the active set settles, Newton
  // converges quadratically: 9e-6 -> 1e-10 in one step here.)
  int ns = 0;
  const ActiveModel model = TwoBallsModel(&ns);
  RigidTransform push;
  Eigen::Matrix3Xd free;
  ASSERT_TRUE(PushBalls(model, 0.3, &push, &free));
  const ContactOptions options = BallsContactOptions(0.4);
  const ContactSolver contact(model, options);
  std::vector<SelfContactPair> pairs =
      contact.DetectSelfContacts(EmbeddedPositions(model.embedding, model.mesh.tets, free));
  ASSERT_GT(pairs.size(), 20u);
  for (SelfContactPair& pair : pairs) pair.offset = 3 * options.thickness;
  const SelfContactTerm term(pairs, options.thickness, std::numeric_limits<double>::infinity(),
                             std::numeric_limits<double>::infinity());
  const ShapeTargetModel physics(model.mesh, model.mu);
  QuasistaticSolveReport reports[2];
  Eigen::Matrix3Xd results[2];
  for (int newton = 0; newton < 2; ++newton) {
    QuasistaticSolverOptions solver_options = DefaultContactSolverOptions();
    solver_options.relative_force_tolerance = 1e-7;
    if (newton == 0) {
      solver_options.method = EquilibriumMethod::kLevenbergMarquardt;
      solver_options.newton_relative_force = 0.0;
    }
    QuasistaticSolver solver(physics, ModelBoundaryConditions(model, {push}), solver_options);
    solver.AddEnergyTerm(&term);
    solver.SetPositions(free);
    reports[newton] = solver.Solve();
    results[newton] = solver.positions();
  }
  const QuasistaticSolveReport& lm = reports[0];
  const QuasistaticSolveReport& newton = reports[1];
  EXPECT_TRUE(newton.converged) << newton.Summary();
  EXPECT_GT(newton.newton_steps, 0) << newton.Summary();
  EXPECT_NE(newton.termination.find("Newton: force tolerance reached"), std::string::npos)
      << newton.Summary();
  // Levenberg-Marquardt alone ends at its round-off floor near this tolerance (its cost
  // changes become noise), converged or not; L-BFGS and Newton reach the tolerance with
  // fewer factorizations than Levenberg-Marquardt takes iterations (each of which
  // factorizes its normal equations).
  EXPECT_EQ(lm.newton_steps, 0) << lm.Summary();
  EXPECT_LE(newton.final_max_force, newton.force_tolerance) << newton.Summary();
  EXPECT_LT(newton.factorizations, lm.lm_iterations) << lm.Summary() << "\n" << newton.Summary();
  // The same equilibrium (to what Levenberg-Marquardt reached).
  EXPECT_LT((results[0] - results[1]).cwiseAbs().maxCoeff(), 1e-3) << lm.Summary();
}

TEST(ContactSolverTest, SpheresPushedThroughEachOtherAreSeparatedAlongThePath) {
  // The right ball pushed 0.45 towards the left one: without contact its front passes
  // 0.35 through the left ball, deeper than max_depth (0.25), so rounds that start there
  // cannot tell the sides; the path from rest catches the contact as it begins.
  int ns = 0;
  const ActiveModel model = TwoBallsModel(&ns);
  RigidTransform push;
  Eigen::Matrix3Xd free;
  ASSERT_TRUE(PushBalls(model, 0.45, &push, &free));
  ContactOptions options = BallsContactOptions(0.25);
  options.path_steps = 0;
  // (Point-triangle pairs only: edge-edge pairs keep the sides of rest without a path
  // and would separate these balls, whose edges cross shallowly.)
  options.edge_contact = false;
  ContactReport direct, path;
  Eigen::Matrix3Xd state;
  std::string error;
  ASSERT_TRUE(ContactSolver(model, options)
                  .Resolve(IdentityActuations(model.mesh.num_tets()), {push}, {}, free,
                           &state, &direct, &error))
      << error;
  EXPECT_GT(direct.self_intersections_after, 20) << direct.Summary();
  options.path_steps = 8;
  options.edge_contact = true;
  ASSERT_TRUE(ContactSolver(model, options)
                  .Resolve(IdentityActuations(model.mesh.num_tets()), {push}, {}, free,
                           &state, &path, &error))
      << error;
  EXPECT_GT(path.self_intersections_before, 100) << path.Summary();
  EXPECT_EQ(path.self_intersections_after, 0) << path.Summary();
  EXPECT_TRUE(path.converged) << path.Summary();
  EXPECT_GE(path.path_steps, 8);
  const double gap = BallsGap(model, ns, state);
  EXPECT_GE(gap, -0.01) << path.Summary();
  EXPECT_LE(gap, 3 * options.thickness) << path.Summary();
}

// Two unit cubes, each a 2 x 2 x 2 lattice turned 45 degrees to present an edge: the
// lower one's ridge along x (held at its bottom), the upper one's along y above it
// (driven at its top by bone "driver"), 0.1 apart where they cross. Both ridges cross
// in the middle of an edge, so that no vertex meets a face when the upper cube is
// pushed down by less than about 0.25 beyond touching: an edge-edge contact.
ActiveModel CrossedRidgesModel() {
  LatticeOptions lattice;
  lattice.nx = lattice.ny = lattice.nz = 2;
  lattice.spacing = 0.5;
  lattice.origin = Eigen::Vector3d(-0.5, -0.5, -0.5);
  const TetMesh cube = MakeLatticeMesh(lattice);
  const double ridge = std::sqrt(0.5);  // half the cube's face diagonal
  const Eigen::Matrix3d lower_turn =
      Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d upper_turn =
      Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  TetMesh mesh;
  const int n = cube.num_vertices();
  mesh.vertices.resize(3, 2 * n);
  mesh.vertices.leftCols(n) = lower_turn * cube.vertices;
  mesh.vertices.rightCols(n) =
      (upper_turn * cube.vertices).colwise() + Eigen::Vector3d(0.25, 0.25, 2 * ridge + 0.1);
  mesh.tets.resize(4, 2 * cube.num_tets());
  mesh.tets << cube.tets, (cube.tets.array() + n).matrix();
  std::vector<int> held;
  Bone driver;
  driver.name = "driver";
  for (int v = 0; v < 2 * n; ++v) {
    if (v < n && mesh.vertices(2, v) < -ridge + 1e-9) held.push_back(v);
    if (v >= n && mesh.vertices(2, v) > 3 * ridge + 0.1 - 1e-9) driver.vertices.push_back(v);
  }
  ActiveModel model = BlockModel(mesh, held);
  model.bones = {driver};
  return model;
}

TEST(ContactSolverTest, CrossedRidgesStopAtTheirEdgesWithEdgeEdgePairs) {
  const ActiveModel model = CrossedRidgesModel();
  RigidTransform push;
  push.translation = Eigen::Vector3d(0, 0, -0.25);  // the ridges overlap by 0.15
  Eigen::Matrix3Xd free;
  ASSERT_TRUE(ContactFreeEquilibrium(model, push, &free));
  ContactOptions options;
  options.thickness = 0.01;
  options.search_radius = 0.1;
  options.max_depth = 0.3;
  options.exclusion_rings = 1;
  // The crossing ridge edges: the lower one from (0, 0, r) to (0.5, 0, r), the upper one
  // from (0.25, -0.25, r + 0.1) to (0.25, 0.25, r + 0.1) at rest (r = sqrt(1/2)).
  const double r = std::sqrt(0.5);
  auto vertex_at = [&](const Eigen::Vector3d& p) {
    for (int v = 0; v < model.mesh.num_vertices(); ++v) {
      if ((model.mesh.vertices.col(v) - p).norm() < 1e-9) return v;
    }
    LOG(FATAL) << "no vertex at " << p.transpose();
    return -1;
  };
  const int lower[2] = {vertex_at(Eigen::Vector3d(0, 0, r)), vertex_at(Eigen::Vector3d(0.5, 0, r))};
  const int upper[2] = {vertex_at(Eigen::Vector3d(0.25, -0.25, r + 0.1)),
                        vertex_at(Eigen::Vector3d(0.25, 0.25, r + 0.1))};
  for (int path_steps : {0, 8}) {
    options.path_steps = path_steps;
    for (bool edge_contact : {false, true}) {
      options.edge_contact = edge_contact;
      Eigen::Matrix3Xd state;
      ContactReport report;
      std::string error;
      ASSERT_TRUE(ContactSolver(model, options)
                      .Resolve(IdentityActuations(model.mesh.num_tets()), {push}, {}, free,
                               &state, &report, &error))
          << error;
      EXPECT_GT(report.self_intersections_before, 0) << report.Summary();
      if (!edge_contact) {
        // Point-triangle pairs alone let the edges pass.
        EXPECT_GT(report.self_intersections_after, 0) << report.Summary();
        continue;
      }
      EXPECT_EQ(report.self_intersections_after, 0) << "path " << path_steps << ": "
                                                    << report.Summary();
      EXPECT_TRUE(report.converged) << report.Summary();
      // Either the upper ridge rests on the lower one, about the thickness above it (the
      // common normal of x and y is z), or, the crossing being unstable without friction,
      // the soft cubes have sheared until the ridges slid past each other: then the edges
      // are apart. Never do they pass through each other.
      double s = 0, u = 0, w = 0;
      ASSERT_TRUE(EdgeDistance(state.col(lower[0]), state.col(lower[1]), state.col(upper[0]),
                               state.col(upper[1]), kMinEdgeSine, &s, nullptr, &u, &w));
      const bool crossing = std::min(u, w) >= -options.margin && std::max(u, w) <= 1.0 + options.margin;
      if (crossing) {
        const double gap = -s;
        EXPECT_GE(gap, -0.005) << "path " << path_steps << ": " << report.Summary();
        EXPECT_LE(gap, 3 * options.thickness) << "path " << path_steps << ": " << report.Summary();
      } else {
        EXPECT_GE(SegmentSegmentDistance(state.col(lower[0]), state.col(lower[1]),
                                         state.col(upper[0]), state.col(upper[1])),
                  options.thickness)
            << "path " << path_steps << ": " << report.Summary();
      }
    }
  }
}

}  // namespace
}  // namespace aqs
