#include "contact/obstacle_contact_term.h"

#include <algorithm>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include "contact/contact_solver.h"
#include "equilibrium/quasistatic_solver.h"
#include "model/active_model.h"
#include "testing/contact_scenes.h"
#include "testing/test_meshes.h"
#include "testing/element_states.h"
#include "testing/energy_term_checks.h"
#include "testing/finite_difference.h"
#include "testing/gradient_check.h"

namespace aqs {
namespace {

using testing::BoxSurface;
using testing::DenseStiffness;
using testing::DifferencedHessian;
using testing::Stencil;

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
    ceres::GradientChecker::ProbeResults results;
    testing::ProbeJacobians(*cost, parameters, 1e-7, &results, testing::RiddersFrom(1e-4));
    EXPECT_LT(testing::MaxBlockError(results, 1e-10), 1e-6) << results.error_log;
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

// A contact point of the scene below: its box, its position and closest point in the box's
// frame, and what fixes the Hessian of the distance there (the curvature the Gauss-Newton
// stiffness leaves out): 0 at a face, (I - g g^T - e e^T) / d at an edge of direction e,
// (I - g g^T) / d at a corner, g the unit direction from the closest point.
struct ObstaclePoint {
  std::string feature;
  int box;
  Eigen::Vector3d local;
  Eigen::Vector3d closest;  // local
  Eigen::Vector3d edge;     // local edge direction (zero: not an edge)
  bool face;
};

// A point near the first obstacle and deep inside the second: the second's search is
// limited (to max(10 thickness, the best so far)), yet its penetration is found whole and
// wins (it was reported as outside, and the point got no force).
TEST(ObstacleContactTermTest, DeepPenetrationOfALaterObstacleIsFound) {
  Eigen::Matrix3Xd v1, v2;
  Eigen::Matrix3Xi t1, t2;
  BoxSurface(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 2, 2), &v1, &t1);
  BoxSurface(Eigen::Vector3d(1.6, -1, -1), Eigen::Vector3d(3.1, 3, 3), &v2, &t2);
  const Obstacle first("first", v1, t1), second("second", v2, t2);
  const std::vector<PointStencil> points = {Stencil(0, Eigen::Vector4d(1, 0, 0, 0))};
  const double thickness = 0.02;  // searches of the second obstacle reach 0.3 at most
  const ObstacleContactTerm term(points, Eigen::VectorXd::Ones(1), thickness, {&first, &second});
  // 0.3 from the first box's face x = 2, 0.7 inside the second box (from its face x = 1.6;
  // 0.8 from x = 3.1).
  const Eigen::Vector3d p(2.3, 1.0, 1.0);
  Eigen::Vector3d gradient;
  EXPECT_NEAR(term.Distance(p, &gradient), -0.7, 1e-12);
  EXPECT_LT((gradient - Eigen::Vector3d(-1, 0, 0)).norm(), 1e-12);
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, 4);
  x.col(0) = p - points[0].offset;  // the stencil's position is p
  Eigen::Matrix3Xd force = Eigen::Matrix3Xd::Zero(3, 4);
  EXPECT_NEAR(term.AddEnergyAndGradient(x, &force), 0.5 * (thickness + 0.7) * (thickness + 0.7),
              1e-12);
  EXPECT_GT(force.col(0).norm(), 0.5);
}

TEST(ObstacleContactTermTest, EdgeAndCornerContactsOnRotatedBoxes) {
  // Two rotated boxes at least 1 apart (so each point has one unambiguous nearest obstacle),
  // and points outside their edges and corners (closest feature: the edge or corner) and
  // inside near a face, all within the thickness 0.1. Each probe lies at least 0.02 from the
  // boundaries of its closest feature's region, so differencing stays smooth.
  std::mt19937 rng(17);
  const Eigen::Matrix3d rotation[2] = {testing::RandomRotation(&rng),
                                       testing::RandomRotation(&rng)};
  const Eigen::Vector3d shift[2] = {Eigen::Vector3d(0.2, -0.1, 0.3),
                                    Eigen::Vector3d(0.5, 0.4, 5.5)};
  const Eigen::Vector3d size[2] = {Eigen::Vector3d(2, 1, 1), Eigen::Vector3d(1, 1, 1)};
  std::vector<Obstacle> boxes;
  for (int b = 0; b < 2; ++b) {
    Eigen::Matrix3Xd v;
    Eigen::Matrix3Xi t;
    BoxSurface(Eigen::Vector3d(0, 0, 0), size[b], &v, &t);
    boxes.emplace_back("box" + std::to_string(b), (rotation[b] * v).colwise() + shift[b], t);
  }
  const Eigen::Vector3d none = Eigen::Vector3d::Zero();
  const std::vector<ObstaclePoint> probes = {
      {"edge y = z = 1 of box 0", 0, Eigen::Vector3d(0.8, 1.03, 1.04), Eigen::Vector3d(0.8, 1, 1),
       Eigen::Vector3d(1, 0, 0), false},
      {"corner (2, 1, 1) of box 0", 0, Eigen::Vector3d(2.02, 1.03, 1.06), Eigen::Vector3d(2, 1, 1),
       none, false},
      {"edge x = 1, z = 0 of box 1", 1, Eigen::Vector3d(1.04, 0.4, -0.03),
       Eigen::Vector3d(1, 0.4, 0), Eigen::Vector3d(0, 1, 0), false},
      {"corner (0, 0, 0) of box 1", 1, Eigen::Vector3d(-0.03, -0.02, -0.05),
       Eigen::Vector3d(0, 0, 0), none, false},
      {"inside box 1 near the face z = 1", 1, Eigen::Vector3d(0.5, 0.6, 0.97),
       Eigen::Vector3d(0.5, 0.6, 1), none, true},
  };
  const int m = static_cast<int>(probes.size());
  const int n = 4 * m;
  // Point i: vertices 4 i .. 4 i + 3 scattered about it, placed so that it sits at its probe.
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<PointStencil> points;
  Eigen::VectorXd stiffness(m);
  Eigen::Matrix3Xd x(3, n);
  std::vector<Eigen::Vector3d> world(m);
  for (int i = 0; i < m; ++i) {
    Eigen::Vector4d w(1.0 + 0.5 * uniform(rng), 1.0 + 0.5 * uniform(rng), 1.0 + 0.5 * uniform(rng),
                      1.0 + 0.5 * uniform(rng));
    w /= w.sum();
    points.push_back(Stencil(4 * i, w));
    stiffness[i] = 2.0 + i;
    const ObstaclePoint &probe = probes[i];
    world[i] = rotation[probe.box] * probe.local + shift[probe.box];
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int j = 0; j < 4; ++j) {
      x.col(4 * i + j) = 0.1 * Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
      centre += w[j] * x.col(4 * i + j);
    }
    for (int j = 0; j < 4; ++j) x.col(4 * i + j) += world[i] - points[i].offset - centre;
  }
  const double thickness = 0.1;
  const ObstacleContactTerm term(points, stiffness, thickness, {&boxes[0], &boxes[1]});
  Eigen::Matrix4Xi tets(4, m);
  for (int i = 0; i < m; ++i) tets.col(i) = Eigen::Vector4i(4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3);

  // The curvature term the stiffness omits: -k gap w_j w_l Hess d per vertex pair.
  Eigen::MatrixXd omitted = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (int i = 0; i < m; ++i) {
    const ObstaclePoint &probe = probes[i];
    SCOPED_TRACE(probe.feature);
    const Eigen::Vector3d p = points[i].Position(x);
    ASSERT_LT((p - world[i]).norm(), 1e-12);
    Eigen::Vector3d g;
    const double d = term.Distance(p, &g);
    // The expected distance and gradient, in the box's frame.
    const Eigen::Vector3d from_closest = probe.local - probe.closest;
    const double expected = probe.face ? -from_closest.norm() : from_closest.norm();
    ASSERT_NEAR(d, expected, 1e-12);
    const Eigen::Vector3d local_g = rotation[probe.box].transpose() * g;
    ASSERT_LT((local_g - (probe.face ? -1.0 : 1.0) * from_closest.normalized()).norm(), 1e-12);
    ASSERT_LT(d, thickness);
    if (probe.face) continue;  // Hess d = 0
    const Eigen::Vector3d e = rotation[probe.box] * probe.edge;
    const Eigen::Matrix3d hess_d =
        (Eigen::Matrix3d::Identity() - g * g.transpose() - e * e.transpose()) / d;
    const double gap = thickness - d;
    for (int j = 0; j < 4; ++j) {
      for (int l = 0; l < 4; ++l) {
        omitted.block<3, 3>(3 * (4 * i + j), 3 * (4 * i + l)) =
            -stiffness[i] * gap * points[i].weight[j] * points[i].weight[l] * hess_d;
      }
    }
  }

  for (int i = 0; i < m; ++i) {
    SCOPED_TRACE(probes[i].feature);
    std::unique_ptr<ceres::CostFunction> cost(term.NewCostFunction(i));
    const double *parameters[4];
    for (int j = 0; j < 4; ++j) parameters[j] = x.col(points[i].vertex[j]).data();
    double r = 0;
    ASSERT_TRUE(cost->Evaluate(parameters, &r, nullptr));
    EXPECT_GT(r, 0.0) << "in contact";
    ceres::GradientChecker::ProbeResults results;
    testing::ProbeJacobians(*cost, parameters, 1e-7, &results, testing::RiddersFrom(1e-4));
    // Measured: at most 4.9e-12.
    EXPECT_LT(testing::MaxBlockError(results, 1e-10), 5e-10) << results.error_log;
  }
  auto energy = [&](const Eigen::VectorXd &flat) {
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, n);
    return term.AddEnergyAndGradient(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, n), &g);
  };
  Eigen::Matrix3Xd gradient = Eigen::Matrix3Xd::Zero(3, n);
  term.AddEnergyAndGradient(x, &gradient);
  // Measured: 1.9e-9 (round-off of distances at coordinates of ~5).
  EXPECT_LT(
      testing::RelativeError(Eigen::Map<const Eigen::VectorXd>(gradient.data(), 3 * n),
                             testing::CentralDifferenceGradient(
                                 energy, Eigen::Map<const Eigen::VectorXd>(x.data(), 3 * n), 1e-6)),
      2e-7);
  // The stiffness is the Gauss-Newton part only (obstacle_contact_term.h), exact at the face
  // point only: the differenced Hessian minus it is the omitted curvature term
  // -k gap w_j w_l Hess d of the edge and corner points, which is not small here.
  const Eigen::MatrixXd stiffness_matrix = DenseStiffness(term, x, tets);
  const Eigen::MatrixXd hessian = DifferencedHessian(term, x);
  EXPECT_GT(testing::RelativeError(stiffness_matrix, hessian),
            0.1);  // measured 0.9
  // Measured: 5.0e-9 (the corner form of Hess d at the edges gives 0.83).
  EXPECT_LT(testing::RelativeError(hessian - stiffness_matrix, omitted), 5e-7);
}

// The nearest obstacle distance's penalty, as ObstacleContactTerm was before its sum
// over features (2026-12-07): E = sum_i k_i / 2 max(0, t - d(p_i))^2 with the Gauss-Newton
// stiffness k_i grad d grad d^T. The reference whose Newton steps crawl at a crease.
class NearestPenaltyTerm : public EnergyTerm {
 public:
  NearestPenaltyTerm(const std::vector<PointStencil>& points, double stiffness, double thickness,
                     const Obstacle* obstacle)
      : points_(points), stiffness_(stiffness), thickness_(thickness), obstacle_(obstacle) {}

  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override {
    double energy = 0.0;
    for (const PointStencil& s : points_) {
      Eigen::Vector3d g;
      const double d = obstacle_->SignedDistance(s.Position(x), &g);
      if (!(d < thickness_)) continue;
      energy += 0.5 * stiffness_ * (thickness_ - d) * (thickness_ - d);
      for (int j = 0; j < 4; ++j) {
        gradient->col(s.vertex[j]) -= stiffness_ * (thickness_ - d) * s.weight[j] * g;
      }
    }
    return energy;
  }
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x, const StiffnessPattern& pattern,
                    StiffnessKind /*kind*/, std::vector<double>* values) const override {
    for (const PointStencil& s : points_) {
      Eigen::Vector3d g;
      if (!(obstacle_->SignedDistance(s.Position(x), &g) < thickness_)) continue;
      Eigen::MatrixXd hessian(12, 12);
      for (int j = 0; j < 4; ++j) {
        for (int l = 0; l < 4; ++l) {
          hessian.block<3, 3>(3 * j, 3 * l) =
              stiffness_ * s.weight[j] * s.weight[l] * g * g.transpose();
        }
      }
      AddVertexHessian(std::vector<int>(s.vertex, s.vertex + 4), hessian, pattern, values);
    }
  }
  void AddResidualBlocks(ceres::Problem* /*problem*/,
                         const std::vector<double*>& /*vertex_blocks*/) const override {
    ADD_FAILURE() << "Newton solves do not build a Ceres problem";
  }

 private:
  std::vector<PointStencil> points_;
  double stiffness_;
  double thickness_;
  const Obstacle* obstacle_;
};

// The Ceres residual (what the Levenberg-Marquardt phase of contact solves uses) in a
// concave crease, where the penalty is the C1 sum over the crease's features rather than
// one distance's, and barely in contact (r -> 0 as the depth reaches the thickness).
TEST(ObstacleContactTermTest, ResidualJacobianInACreaseAndAtTheEdgeOfContact) {
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  const double depth = 0.2, thickness = 0.05;
  testing::NotchedPrismSurface(depth, &v, &t);
  std::mt19937 rng(29);
  const Eigen::Matrix3d rotation = testing::RandomRotation(&rng);
  const Eigen::Vector3d shift(0.3, -0.2, 0.5);
  const Obstacle notch("notch", (rotation * v).colwise() + shift, t);
  // Local points: 0.03 above the crease and 0.01 off its bisector; and above the right
  // face (from (0, -depth) to (1, 0)) at 1e-6 less than the thickness along its normal.
  const Eigen::Vector3d face_normal = Eigen::Vector3d(-depth, 1.0, 0.0).normalized();
  const std::vector<std::pair<std::string, Eigen::Vector3d>> locals = {
      {"in the crease", Eigen::Vector3d(0.01, -depth + 0.03, 0.2)},
      {"at the edge of contact",
       Eigen::Vector3d(0.5, -0.5 * depth, -0.3) + (thickness - 1e-6) * face_normal}};
  std::normal_distribution<double> noise(0.0, 0.02);
  const Eigen::Vector4d w(0.1, 0.2, 0.3, 0.4);
  for (const auto& [name, local] : locals) {
    SCOPED_TRACE(name);
    const PointStencil stencil = testing::Stencil(0, w);
    // Vertices about the point, so that the stencil's point is exactly the local point.
    Eigen::Matrix3Xd x(3, 4);
    for (int j = 0; j < 4; ++j) x.col(j) = Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    const Eigen::Vector3d p = rotation * local + shift;
    const Eigen::Vector3d correction = p - stencil.Position(x);
    x.colwise() += correction;  // the weights sum to 1
    ASSERT_LT((stencil.Position(x) - p).norm(), 1e-14);
    const ObstacleContactTerm term({stencil}, Eigen::VectorXd::Constant(1, 3.0), thickness,
                                   {&notch});
    std::unique_ptr<ceres::CostFunction> cost(term.NewCostFunction(0));
    const double* parameters[4];
    for (int j = 0; j < 4; ++j) parameters[j] = x.col(j).data();
    double r = 0;
    ASSERT_TRUE(cost->Evaluate(parameters, &r, nullptr));
    EXPECT_GT(r, 0.0) << "in contact";
    ceres::GradientChecker::ProbeResults results;
    testing::ProbeJacobians(*cost, parameters, 1e-7, &results, testing::RiddersFrom(1e-7));
    EXPECT_LT(testing::MaxBlockError(results, 1e-10), 1e-6) << results.error_log;
  }
}

TEST(ObstacleContactTermTest, ABlockPressedIntoACreaseConvergesWhereTheNearestPenaltyStalls) {
  // A block [-0.5, 0.5] x [0, 0.75] x [-0.25, 0.25] (4 x 3 x 2 cubes) whose top is pushed
  // down by 0.2 and sideways by 0.01 into a shallow valley: the notched prism with faces
  // 11.3 degrees off the horizontal (as at the demo's stalled point, 11.9), its crease
  // along z at x = 0, y = -0.05, below the bottom row of vertices at x = 0.
  TetMesh block = testing::BarMesh(4, 3, 2, 0.25);
  block.vertices.colwise() += Eigen::Vector3d(-0.5, 0.0, -0.25);
  std::vector<int> top, bottom;
  for (int v = 0; v < block.num_vertices(); ++v) {
    if (block.vertices(1, v) > 0.75 - 1e-9) top.push_back(v);
    if (block.vertices(1, v) < 1e-9) bottom.push_back(v);
  }
  ActiveModel model = testing::BlockModel(block, {});
  Bone lid;
  lid.name = "lid";
  lid.vertices = top;
  model.bones = {lid};
  RigidTransform push;
  push.translation = Eigen::Vector3d(0.01, -0.2, 0);
  Eigen::Matrix3Xd free;
  ASSERT_TRUE(testing::ContactFreeEquilibrium(model, push, &free));
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  testing::NotchedPrismSurface(0.2, &v, &t);
  const Obstacle notch("notch", v.colwise() + Eigen::Vector3d(0, 0.15, 0), t);
  std::vector<PointStencil> points;
  for (int b : bottom) points.push_back(EmbeddingStencil(model.embedding, block.tets, b));
  const double thickness = 0.02, stiffness = 300.0;
  const ObstacleContactTerm sum(points, Eigen::VectorXd::Constant(points.size(), stiffness),
                                thickness, {&notch});
  const NearestPenaltyTerm nearest(points, stiffness, thickness, &notch);
  const ShapeTargetModel physics(block, model.mu);
  QuasistaticSolveReport reports[2];
  for (int k = 0; k < 2; ++k) {
    QuasistaticSolverOptions options = DefaultContactSolverOptions();
    options.relative_force_tolerance = 1e-9;
    QuasistaticSolver solver(physics, ModelBoundaryConditions(model, {push}), options);
    solver.AddEnergyTerm(k == 0 ? static_cast<const EnergyTerm*>(&nearest) : &sum);
    solver.SetPositions(free);
    reports[k] = solver.Solve();
  }
  const QuasistaticSolveReport& before = reports[0];
  const QuasistaticSolveReport& after = reports[1];
  EXPECT_TRUE(after.converged) << after.Summary();
  EXPECT_FALSE(after.newton_stalled) << after.Summary();
  // The nearest penalty's Newton phase ends where no step along its direction lowers the
  // energy (a kink: measured largest force 3.1e-3 after 16 factorizations, the tolerance
  // 3.8e-11); the sum converges in 3.
  EXPECT_FALSE(before.converged) << before.Summary();
  EXPECT_GT(before.final_max_force, 1e-4) << before.Summary();
  EXPECT_LE(after.factorizations, 6) << after.Summary();
  EXPECT_LT(after.factorizations, before.factorizations)
      << before.Summary() << "\n" << after.Summary();
}

}  // namespace
}  // namespace aqs
