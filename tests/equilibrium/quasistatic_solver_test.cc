#include "equilibrium/quasistatic_solver.h"

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "testing/element_states.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

using testing::BarMesh;
using testing::LeftFaceFixed;

// A smooth bend and twist of the bar (a deformation with non-trivial rotations).
Eigen::Matrix3Xd BendAndTwist(const Eigen::Matrix3Xd& rest) {
  Eigen::Matrix3Xd y(3, rest.cols());
  for (int v = 0; v < rest.cols(); ++v) {
    const Eigen::Vector3d p = rest.col(v);
    const double bend = 0.25 * p.x();
    const double twist = 0.4 * p.x();
    const Eigen::Vector3d q(p.x(), p.y() * std::cos(twist) - p.z() * std::sin(twist),
                            p.y() * std::sin(twist) + p.z() * std::cos(twist));
    y.col(v) = Eigen::AngleAxisd(bend, Eigen::Vector3d::UnitZ()) * q +
               Eigen::Vector3d(0, 0.1 * p.x() * p.x(), 0);
  }
  return y;
}

QuasistaticSolverOptions TightOptions() {
  QuasistaticSolverOptions options;
  // Tight, near the floating-point floor (see QuasistaticSolverOptions).
  options.relative_force_tolerance = 1e-9;
  options.function_tolerance = 0;
  return options;
}

TEST(QuasistaticSolverTest, IdentityActuationKeepsRestShape) {
  const TetMesh mesh = BarMesh(4, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolver solver(model, LeftFaceFixed(mesh), TightOptions());
  // Start from a perturbed state: the solve must come back to rest.
  std::mt19937 rng(1);
  std::normal_distribution<double> normal(0.0, 0.03);
  Eigen::Matrix3Xd start = mesh.vertices;
  for (int i = 0; i < start.size(); ++i) start.data()[i] += normal(rng);
  solver.SetPositions(start);
  const QuasistaticSolveReport report = solver.Solve();
  EXPECT_TRUE(report.converged) << report.Summary();
  EXPECT_LT((solver.positions() - mesh.vertices).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT(report.final_energy, 1e-16);
}

TEST(QuasistaticSolverTest, PolarFactorTargetsReproduceAnyDeformation) {
  const TetMesh mesh = BarMesh(6, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const Eigen::Matrix3Xd y = BendAndTwist(mesh.vertices);
  BoundaryConditions bc = LeftFaceFixed(mesh);
  bc.positions.resize(3, bc.vertices.size());
  for (size_t i = 0; i < bc.vertices.size(); ++i) bc.positions.col(i) = y.col(bc.vertices[i]);
  QuasistaticSolver solver(model, bc, TightOptions());
  for (int e = 0; e < model.num_elements(); ++e) {
    const Eigen::Matrix3d f = model.DeformationGradient(y, e);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(f.transpose() * f);
    const Eigen::Matrix3d stretch = eig.eigenvectors() *
                                    eig.eigenvalues().cwiseSqrt().asDiagonal() *
                                    eig.eigenvectors().transpose();
    solver.actuation().col(e) = ActuationFromSymmetric(stretch);
  }
  const QuasistaticSolveReport report = solver.Solve();
  EXPECT_TRUE(report.converged) << report.Summary();
  EXPECT_LT((solver.positions() - y).cwiseAbs().maxCoeff(), 1e-7) << report.Summary();
  EXPECT_LT(report.final_energy, 1e-14);
}

TEST(QuasistaticSolverTest, RigidlyMovedSupportsGiveRigidMotion) {
  const TetMesh mesh = BarMesh(4, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 2.0);
  BoundaryConditions bc = LeftFaceFixed(mesh);
  std::mt19937 rng(4);
  const Eigen::Matrix3d r = testing::RandomRotation(&rng);
  const Eigen::Vector3d t(1.0, -0.5, 0.25);
  bc.positions.resize(3, bc.vertices.size());
  for (size_t i = 0; i < bc.vertices.size(); ++i) {
    bc.positions.col(i) = r * mesh.vertices.col(bc.vertices[i]) + t;
  }
  QuasistaticSolver solver(model, bc, TightOptions());
  const QuasistaticSolveReport report = solver.Solve();
  EXPECT_TRUE(report.converged) << report.Summary();
  const Eigen::Matrix3Xd expected = (r * mesh.vertices).colwise() + t;
  EXPECT_LT((solver.positions() - expected).cwiseAbs().maxCoeff(), 1e-7) << report.Summary();
}

TEST(QuasistaticSolverTest, HeterogeneousMuReachesForceTolerance) {
  const TetMesh mesh = BarMesh(5, 2, 2, 0.4);
  Eigen::VectorXd mu(mesh.num_tets());
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> uniform(0.2, 5.0);
  for (int e = 0; e < mu.size(); ++e) mu[e] = uniform(rng);
  const ShapeTargetModel model(mesh, mu);
  QuasistaticSolver solver(model, LeftFaceFixed(mesh), TightOptions());
  solver.actuation() = testing::SmoothActuation(mesh, 0.2);
  const QuasistaticSolveReport report = solver.Solve();
  ASSERT_TRUE(report.converged) << report.Summary();
  EXPECT_GT(report.iterations, 0);
  // Independent check of the equilibrium: forces from the model's own gradient.
  Eigen::Matrix3Xd gradient;
  model.EnergyAndGradient(solver.positions(), solver.actuation(), &gradient);
  double max_free = 0, max_fixed = 0;
  for (int v = 0; v < model.num_vertices(); ++v) {
    const double f = gradient.col(v).norm();
    if (solver.fixed_mask()[v]) {
      max_fixed = std::max(max_fixed, f);
    } else {
      max_free = std::max(max_free, f);
    }
  }
  EXPECT_LE(max_free, report.force_tolerance);
  EXPECT_NEAR(max_free, report.final_max_force, 1e-15);
  EXPECT_GT(max_fixed, 1e3 * report.force_tolerance) << "the support carries load";
  // Fixed vertices did not move.
  for (int v : solver.fixed_vertices()) {
    EXPECT_EQ((solver.positions().col(v) - mesh.vertices.col(v)).norm(), 0.0);
  }
}

TEST(QuasistaticSolverTest, WarmStartAndInPlaceActuationUpdates) {
  const TetMesh mesh = BarMesh(5, 2, 2, 0.4);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolverOptions options;  // defaults: 1e-6 relative force
  QuasistaticSolver solver(model, LeftFaceFixed(mesh), options);
  solver.actuation() = testing::SmoothActuation(mesh, 0.15);
  const QuasistaticSolveReport first = solver.Solve();
  ASSERT_TRUE(first.converged) << first.Summary();
  const Eigen::Matrix3Xd first_positions = solver.positions();
  // Nothing changed: the warm start is already the answer.
  const QuasistaticSolveReport again = solver.Solve();
  EXPECT_TRUE(again.converged);
  EXPECT_EQ(again.iterations, 0);
  // A 1% change of the actuation, in place: few iterations from the warm start.
  solver.actuation() = IdentityActuations(model.num_elements()) +
                       1.01 * (solver.actuation() - IdentityActuations(model.num_elements()));
  const QuasistaticSolveReport warm = solver.Solve();
  ASSERT_TRUE(warm.converged) << warm.Summary();
  EXPECT_LT(warm.iterations, first.iterations);
  EXPECT_GT((solver.positions() - first_positions).norm(), 1e-6);
  // The same answer from a cold start.
  QuasistaticSolver cold(model, LeftFaceFixed(mesh), options);
  cold.actuation() = solver.actuation();
  ASSERT_TRUE(cold.Solve().converged);
  EXPECT_LT((cold.positions() - solver.positions()).cwiseAbs().maxCoeff(), 1e-5);
}

TEST(QuasistaticSolverTest, NonConvergenceIsReported) {
  const TetMesh mesh = BarMesh(5, 2, 2, 0.4);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolverOptions options = TightOptions();
  options.max_iterations = 1;
  options.method = EquilibriumMethod::kLevenbergMarquardt;
  options.newton_relative_force = 0.0;  // Levenberg-Marquardt only
  QuasistaticSolver solver(model, LeftFaceFixed(mesh), options);
  solver.actuation() = testing::SmoothActuation(mesh, 0.4);
  const QuasistaticSolveReport report = solver.Solve();
  EXPECT_FALSE(report.converged);
  EXPECT_GT(report.final_max_force, report.force_tolerance);
  EXPECT_NE(report.Summary().find("NOT CONVERGED"), std::string::npos);
  EXPECT_FALSE(report.termination.empty());
}

// On the uniform bar, and on a bar with jittered vertices (elements of different volumes)
// and a random mu per element: the Levenberg-Marquardt path gets each element's volume
// and mu through its own cost functions (ShapeTargetCostFunction), Newton's through the
// model, so a wrong or uniform volume or mu on one path moves its equilibrium.
class NewtonAndLevenbergMarquardtTest : public ::testing::TestWithParam<bool> {};

TEST_P(NewtonAndLevenbergMarquardtTest, NewtonHybridAndLevenbergMarquardtOnlyAgree) {
  TetMesh mesh = BarMesh(6, 2, 2, 0.4);
  const BoundaryConditions fixed = LeftFaceFixed(mesh);  // before the jitter: the same nine
  Eigen::VectorXd mu = Eigen::VectorXd::Ones(mesh.num_tets());
  if (GetParam()) {
    std::mt19937 rng(10);
    std::uniform_real_distribution<double> jitter(-0.06, 0.06), uniform(0.2, 5.0);
    for (int i = 0; i < mesh.vertices.size(); ++i) mesh.vertices.data()[i] += jitter(rng);
    for (int e = 0; e < mu.size(); ++e) mu[e] = uniform(rng);
  }
  const ShapeTargetModel model(mesh, mu);
  QuasistaticSolverOptions newton;
  newton.relative_force_tolerance = 1e-8;  // above the least-squares floor of LM alone
  QuasistaticSolverOptions hybrid = newton;
  hybrid.method = EquilibriumMethod::kLevenbergMarquardt;
  QuasistaticSolverOptions lm_only = hybrid;
  lm_only.newton_relative_force = 0.0;
  QuasistaticSolver a(model, fixed, lm_only);
  QuasistaticSolver b(model, fixed, hybrid);
  QuasistaticSolver c(model, fixed, newton);
  a.actuation() = testing::SmoothActuation(mesh, 0.3);
  b.actuation() = a.actuation();
  c.actuation() = a.actuation();
  const QuasistaticSolveReport report_a = a.Solve();
  const QuasistaticSolveReport report_b = b.Solve();
  const QuasistaticSolveReport report_c = c.Solve();
  ASSERT_TRUE(report_a.converged) << report_a.Summary();
  ASSERT_TRUE(report_b.converged) << report_b.Summary();
  ASSERT_TRUE(report_c.converged) << report_c.Summary();
  EXPECT_EQ(report_a.newton_steps, 0);
  EXPECT_GT(report_b.newton_steps, 0) << report_b.Summary();
  EXPECT_GT(report_b.lm_iterations, 0) << "from rest, LM does the first part";
  EXPECT_EQ(report_c.lm_iterations, 0) << report_c.Summary();
  EXPECT_GT(report_c.exact_steps, 0) << report_c.Summary();
  // The same force tolerance leaves more displacement on the softer varied bar (its
  // elements with mu = 0.2: 1.03e-7 measured between a and c).
  const double agree = GetParam() ? 1e-6 : 1e-7;
  EXPECT_LT((a.positions() - b.positions()).cwiseAbs().maxCoeff(), agree);
  EXPECT_LT((a.positions() - c.positions()).cwiseAbs().maxCoeff(), agree);
  EXPECT_GT((a.positions() - mesh.vertices).cwiseAbs().maxCoeff(), 0.05) << "it moved";
}

INSTANTIATE_TEST_SUITE_P(UniformAndVaried, NewtonAndLevenbergMarquardtTest, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& info) {
                           return info.param ? "JitteredWithVariedMu" : "Uniform";
                         });

TEST(QuasistaticSolverTest, WarmStartsUseNewtonAndReachRoundOffTolerances) {
  const TetMesh mesh = BarMesh(6, 2, 2, 0.4);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolverOptions options;
  options.relative_force_tolerance = 1e-13;  // below the least-squares floor
  QuasistaticSolver solver(model, LeftFaceFixed(mesh), options);
  solver.actuation() = testing::SmoothActuation(mesh, 0.2);
  const QuasistaticSolveReport cold = solver.Solve();
  ASSERT_TRUE(cold.converged) << cold.Summary();
  const ActuationMatrix identity = IdentityActuations(model.num_elements());
  solver.actuation() = identity + 1.01 * (solver.actuation() - identity);
  const QuasistaticSolveReport warm = solver.Solve();
  ASSERT_TRUE(warm.converged) << warm.Summary();
  EXPECT_EQ(warm.lm_iterations, 0) << warm.Summary();
  EXPECT_LE(warm.newton_steps, 3) << warm.Summary();
  EXPECT_LE(warm.final_max_force, 1e-13 * model.force_scale());
}

TEST(QuasistaticSolverTest, MovingFixedVerticesBetweenSolves) {
  const TetMesh mesh = BarMesh(4, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const BoundaryConditions bc = LeftFaceFixed(mesh);
  QuasistaticSolver solver(model, bc, TightOptions());
  ASSERT_TRUE(solver.Solve().converged);
  Eigen::Matrix3Xd moved(3, bc.vertices.size());
  for (size_t i = 0; i < bc.vertices.size(); ++i) {
    moved.col(i) = mesh.vertices.col(bc.vertices[i]) + Eigen::Vector3d(0, 0.2, 0);
  }
  solver.SetFixedPositions(moved);
  const QuasistaticSolveReport report = solver.Solve();
  ASSERT_TRUE(report.converged) << report.Summary();
  const Eigen::Matrix3Xd expected = mesh.vertices.colwise() + Eigen::Vector3d(0, 0.2, 0);
  EXPECT_LT((solver.positions() - expected).cwiseAbs().maxCoeff(), 1e-7);
}

// A bar held at both ends whose elements want to be 1.6 times longer: compressed, the
// straight state is an equilibrium that the solve from rest can reach by symmetry, and
// beyond the buckling load it is unstable. LeaveUnstableEquilibrium must then find a
// stable (buckled) equilibrium of lower energy; from a stable one it stays there.
// A bar of 16 cubes held at both ends whose fibres want it 1.6 times longer: from rest
// the solve converges, by symmetry, to the straight state, an unstable equilibrium.
struct CompressedHeldBar {
  CompressedHeldBar() : mesh(BarMesh(16, 1, 1, 0.25)), model(mesh, Eigen::VectorXd::Ones(mesh.num_tets())) {
    const double length = mesh.vertices.row(0).maxCoeff();
    for (int v = 0; v < mesh.num_vertices(); ++v) {
      const double x = mesh.vertices(0, v);
      if (x < 1e-9 || x > length - 1e-9) ends.vertices.push_back(v);
    }
    a.resize(6, mesh.num_tets());
    for (int e = 0; e < mesh.num_tets(); ++e) a.col(e) << 1.6, 1, 1, 0, 0, 0;  // Sxx Syy Szz ...
  }
  TetMesh mesh;
  ShapeTargetModel model;
  BoundaryConditions ends;
  ActuationMatrix a;
};

TEST(QuasistaticSolverTest, LeavesUnstableEquilibriaForStableOnes) {
  const CompressedHeldBar bar;
  const TetMesh& mesh = bar.mesh;
  const ShapeTargetModel& model = bar.model;
  const BoundaryConditions& ends = bar.ends;
  const ActuationMatrix& a = bar.a;
  QuasistaticSolver solver(model, ends, TightOptions());
  solver.actuation() = a;
  QuasistaticSolveReport report = solver.Solve();
  ASSERT_TRUE(report.converged) << report.Summary();
  StiffnessFactorization& factorization = *solver.stiffness_factorization();
  std::string error;
  const bool straight_stable =
      factorization.Factorize(solver.positions(), a, StiffnessKind::kExact, &error);
  const double straight_energy = report.final_energy;
  const Eigen::Matrix3Xd straight = solver.positions();
  EXPECT_FALSE(straight_stable) << "the compressed straight bar should be unstable";
  if (!straight_stable) {
    report = solver.LeaveUnstableEquilibrium(1e-2, 3);
    ASSERT_TRUE(report.converged) << report.Summary();
    EXPECT_EQ(report.exact_steps, 0) << "projected steps only";
    EXPECT_LT(report.final_energy, straight_energy * (1.0 - 1e-6));
    EXPECT_TRUE(factorization.Factorize(solver.positions(), a, StiffnessKind::kExact, &error))
        << error;
    EXPECT_GT((solver.positions() - straight).colwise().norm().maxCoeff(), 0.1 * 0.25);
  }
  // From a stable equilibrium it returns to the same one.
  const Eigen::Matrix3Xd stable = solver.positions();
  const double stable_energy = solver.Solve().final_energy;
  report = solver.LeaveUnstableEquilibrium(1e-3, 4);
  ASSERT_TRUE(report.converged) << report.Summary();
  EXPECT_NEAR(report.final_energy, stable_energy, 1e-9 * std::abs(stable_energy));
  EXPECT_LT((solver.positions() - stable).cwiseAbs().maxCoeff(), 1e-5);
  // Fixed vertices never move.
  for (size_t i = 0; i < ends.vertices.size(); ++i) {
    EXPECT_EQ((solver.positions().col(ends.vertices[i]) - mesh.vertices.col(ends.vertices[i])).norm(), 0.0);
  }
}

TEST(QuasistaticSolverTest, EnsureStableLeavesTheSaddleASolveConvergedTo) {
  // Without the check the solve from rest reports the straight bar (a saddle) as
  // converged; with it the same solve ends stable, below the saddle's energy, and says
  // that it left one. The check's factorization counts in the report.
  const CompressedHeldBar bar;
  std::string error;
  QuasistaticSolverOptions options = TightOptions();
  options.num_threads = 1;
  QuasistaticSolver unchecked(bar.model, bar.ends, options);
  unchecked.actuation() = bar.a;
  const QuasistaticSolveReport saddle = unchecked.Solve();
  ASSERT_TRUE(saddle.converged) << saddle.Summary();
  EXPECT_FALSE(saddle.stability_checked);
  ASSERT_FALSE(unchecked.stiffness_factorization()->Factorize(unchecked.positions(), bar.a,
                                                              StiffnessKind::kExact, &error));

  options.ensure_stable = true;
  QuasistaticSolver checked(bar.model, bar.ends, options);
  checked.actuation() = bar.a;
  const QuasistaticSolveReport report = checked.Solve();
  ASSERT_TRUE(report.converged) << report.Summary();
  EXPECT_TRUE(report.stability_checked);
  EXPECT_TRUE(report.stable) << report.Summary();
  EXPECT_GE(report.unstable_escapes, 1);
  EXPECT_GE(report.factorizations, saddle.factorizations + 2) << "two checks at least";
  EXPECT_LT(report.final_energy, saddle.final_energy * (1.0 - 1e-6));
  EXPECT_LE(report.final_max_force, report.force_tolerance);
  EXPECT_NE(report.Path().find("left 1 unstable equilibria, stable"), std::string::npos)
      << report.Path();
  EXPECT_TRUE(checked.stiffness_factorization()->Factorize(checked.positions(), bar.a,
                                                          StiffnessKind::kExact, &error));

  // A stable result costs one factorization more than the unchecked solve, nothing else.
  const QuasistaticSolveReport again = checked.Solve();
  EXPECT_TRUE(again.converged && again.stable) << again.Summary();
  EXPECT_EQ(again.unstable_escapes, 0);
  EXPECT_EQ(again.factorizations, 1);
}

// Where the descent from a perturbed saddle fails (here: the factorization budget runs out
// in it), the saddle is the result again, bit for bit, with its energy and force: the
// solve is converged and not stable, and says why. Budgets from the unchecked solve's
// count upwards are tried; some leave the descent short.
TEST(QuasistaticSolverTest, AFailedEscapeLeavesTheSaddleAsTheResult) {
  const CompressedHeldBar bar;
  QuasistaticSolverOptions options = TightOptions();
  options.num_threads = 1;
  QuasistaticSolver unchecked(bar.model, bar.ends, options);
  unchecked.actuation() = bar.a;
  const QuasistaticSolveReport saddle = unchecked.Solve();
  ASSERT_TRUE(saddle.converged) << saddle.Summary();
  int failed_escapes = 0;
  for (int budget = saddle.factorizations + 1; budget <= saddle.factorizations + 8; ++budget) {
    options.ensure_stable = true;
    options.max_iterations = budget;
    QuasistaticSolver checked(bar.model, bar.ends, options);
    checked.actuation() = bar.a;
    const QuasistaticSolveReport report = checked.Solve();
    if (report.termination.find("the descent from a perturbation of it failed") ==
        std::string::npos) {
      continue;
    }
    ++failed_escapes;
    EXPECT_TRUE(report.converged) << budget << ": " << report.Summary();
    EXPECT_FALSE(report.stable) << budget << ": " << report.Summary();
    EXPECT_EQ(report.unstable_escapes, 0) << budget;
    EXPECT_TRUE(checked.positions() == unchecked.positions()) << budget;
    EXPECT_EQ(report.final_energy, saddle.final_energy) << budget;
    EXPECT_EQ(report.final_max_force, saddle.final_max_force) << budget;
  }
  EXPECT_GE(failed_escapes, 1) << "no budget left the escape's descent short";
}

// Every field of the factor reuse is checked (an infinite tolerance made a warm re-solve
// take 178 CG-solved steps instead of 2; a NaN probe tolerance turned the probe off).
TEST(QuasistaticSolverTest, OptionsCheckEveryFactorReuseField) {
  std::string error;
  EXPECT_TRUE(QuasistaticSolverOptions().Validate(&error)) << error;
  QuasistaticSolverOptions options;
  options.factor_reuse.relative_tolerance = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("factor_reuse.relative_tolerance"), std::string::npos) << error;
  options = QuasistaticSolverOptions();
  options.factor_reuse.probe_tolerance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("factor_reuse.probe_tolerance"), std::string::npos) << error;
  options = QuasistaticSolverOptions();
  options.factor_reuse.refresh_iterations = -1;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("factor_reuse.refresh_iterations"), std::string::npos) << error;
}

// A mesh piece that nothing holds (a lone element beside the held bar, as meshers leave
// and models prepared before 2026-12-07 keep) makes every stiffness singular; whether
// CHOLMOD factorizes it then depends on the sign of a round-off pivot. The stability
// check took such stable equilibria for saddles (3 escapes, then "unstable"), and L-BFGS
// lost its preconditioner. Both now factorize K + 1e-10 mean(diag K) I where K does not.
TEST(QuasistaticSolverTest, AFreePieceIsNotTakenForASaddle) {
  TetMesh mesh = BarMesh(4, 2, 2, 0.5);
  testing::AppendLoneElement(&mesh, 0.5, 0.3);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolverOptions options = TightOptions();
  options.num_threads = 1;
  options.ensure_stable = true;
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 6; ++trial) {
    QuasistaticSolver solver(model, LeftFaceFixed(mesh), options);
    for (int e = 0; e < model.num_elements(); ++e) {
      Eigen::Matrix3d g;
      for (int i = 0; i < 9; ++i) g.data()[i] = 0.1 * normal(rng);
      solver.actuation().col(e) =
          ActuationFromSymmetric(Eigen::Matrix3d::Identity() + 0.5 * (g + g.transpose()));
    }
    Eigen::Matrix3Xd start = mesh.vertices;
    for (int i = 0; i < start.size(); ++i) start.data()[i] += 0.01 * normal(rng);
    solver.SetPositions(start);
    const QuasistaticSolveReport report = solver.Solve();
    ASSERT_TRUE(report.converged) << trial << ": " << report.Summary();
    EXPECT_TRUE(report.stable) << trial << ": " << report.Summary();
    EXPECT_EQ(report.unstable_escapes, 0) << trial << ": " << report.Summary();
    EXPECT_EQ(report.termination.find("no preconditioner"), std::string::npos)
        << trial << ": " << report.Summary();
    EXPECT_LE(report.factorizations, 12) << trial << ": " << report.Summary();
  }
}

// An energy term coupling two vertices of different elements (its pattern needs them),
// with no energy of its own: only its couplings matter here.
class CouplingTerm : public EnergyTerm {
 public:
  CouplingTerm(int a, int b) : a_(a), b_(b) {}
  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& /*x*/,
                              Eigen::Matrix3Xd* /*gradient*/) const override {
    return 0.0;
  }
  void AppendVertexCouplings(std::vector<std::vector<int>>* couplings) const override {
    couplings->push_back({a_, b_});
  }
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& /*x*/,
                    const StiffnessPattern& /*pattern*/, StiffnessKind /*kind*/,
                    std::vector<double>* /*values*/) const override {}
  void AddResidualBlocks(ceres::Problem* /*problem*/,
                         const std::vector<double*>& /*vertex_blocks*/) const override {}

 private:
  int a_, b_;
};

// The solver keeps references to its model: temporaries do not compile.
static_assert(!std::is_constructible_v<QuasistaticSolver, ShapeTargetModel&&,
                                       const BoundaryConditions&>);
static_assert(std::is_constructible_v<QuasistaticSolver, const ShapeTargetModel&,
                                      const BoundaryConditions&>);

// Mistakes an embedder makes (the embedder's review, 2026-12-07): each is named, none
// is read past the solver's storage or solved silently.
TEST(QuasistaticSolverTest, MisusesAreCaughtOrRefused) {
  const TetMesh mesh = BarMesh(3, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolver solver(model, LeftFaceFixed(mesh));
  // An actuation of another mesh: the sizes are checked even under NDEBUG (a Map
  // assignment read past the smaller matrix and "converged").
  const ActuationMatrix small = IdentityActuations(model.num_elements() - 2);
  EXPECT_DEATH(solver.actuation() = small,
               "the solver's actuation is 6 x [0-9]+ \\(one column per element\\); a matrix "
               "of 6 x [0-9]+ was assigned");
  const Eigen::MatrixXd nine = Eigen::MatrixXd::Zero(9, model.num_elements());
  EXPECT_DEATH(solver.actuation() = nine, "a matrix of 9 x [0-9]+ was assigned");
  solver.actuation() = testing::SmoothActuation(mesh, 0.2);  // the right size: taken
  solver.actuation().col(3) = IdentityActuations(1);
  // Options are checked as the constructor checks them.
  QuasistaticSolverOptions bad;
  bad.relative_force_tolerance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_DEATH(solver.set_options(bad), "QuasistaticSolverOptions: .*relative_force_tolerance");
  // A non-finite prescribed position (a lost marker) is refused by the solve, by vertex.
  Eigen::Matrix3Xd fixed = solver.fixed_positions();
  fixed(1, 2) = std::numeric_limits<double>::quiet_NaN();
  solver.SetFixedPositions(fixed);
  const QuasistaticSolveReport refused = solver.Solve();
  EXPECT_TRUE(refused.refused);
  EXPECT_FALSE(refused.converged);
  EXPECT_NE(refused.termination.find("refused: the prescribed position of fixed vertex " +
                                     std::to_string(solver.fixed_vertices()[2]) +
                                     " is not finite"),
            std::string::npos)
      << refused.Summary();
  solver.SetFixedPositions(mesh.vertices(Eigen::all, solver.fixed_vertices()));
  const QuasistaticSolveReport solved = solver.Solve();
  EXPECT_TRUE(solved.converged) << solved.Summary();
  EXPECT_FALSE(solved.refused);
  // A coupling term would replace the factorization a differentiator holds.
  const CouplingTerm coupling(0, model.num_vertices() - 1);
  const CouplingTerm other(1, model.num_vertices() - 2);
  QuasistaticSolver early(model, LeftFaceFixed(mesh));
  early.AddEnergyTerm(&coupling);  // before the factorization is handed out: fine
  early.stiffness_factorization();
  EXPECT_DEATH(early.AddEnergyTerm(&other), "add the energy terms first");
}

}  // namespace
}  // namespace aqs
