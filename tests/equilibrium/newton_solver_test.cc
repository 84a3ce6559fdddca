#include "equilibrium/newton_solver.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>

#include <Eigen/Eigenvalues>
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "equilibrium/quasistatic_solver.h"
#include "equilibrium/energy_term.h"
#include "mesh/lattice.h"
#include "physics/stiffness_assembly.h"
#include "sparse/stiffness_pattern.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

using testing::BarMesh;
using testing::CurlActuation;
using testing::LeftFaceFixed;

double ExtentAngle(const Eigen::Matrix3Xd& x, const TetMesh& mesh) {
  // The direction of the bar's free end relative to +x, in degrees.
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  int count = 0;
  const double x_max = mesh.vertices.row(0).maxCoeff();
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) > x_max - 1e-9) {
      tip += x.col(v);
      ++count;
    }
  }
  tip /= count;
  return std::atan2(tip.y(), tip.x()) * 180.0 / M_PI;
}

NewtonSolverOptions Options(const ShapeTargetModel& model, double tolerance) {
  NewtonSolverOptions options;
  options.force_tolerance = tolerance * model.force_scale();
  options.exact_force_threshold = 1e-2 * model.force_scale();
  return options;
}

TEST(NewtonSolverTest, CurlsABarFromRestInFewFactorizations) {
  const TetMesh mesh = BarMesh(16, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const BoundaryConditions bc = LeftFaceFixed(mesh);
  QuasistaticSolverOptions options;
  options.relative_force_tolerance = 1e-10;
  QuasistaticSolver solver(model, bc, options);
  for (double amount : {0.25, 0.4, 0.6}) {
    solver.actuation() = CurlActuation(mesh, amount);
    solver.SetPositions(mesh.vertices);
    const QuasistaticSolveReport report = solver.Solve();
    ASSERT_TRUE(report.converged) << report.Summary();
    // L-BFGS far from equilibrium (its preconditioner factorized in the first solve
    // only), exact Newton near it.
    EXPECT_GT(report.lbfgs_iterations, 0) << report.Summary();
    EXPECT_GT(report.exact_steps, 0) << report.Summary();
    EXPECT_LE(report.factorizations, amount == 0.25 ? 10 : 9) << report.Summary();
    EXPECT_LT(report.final_energy, report.initial_energy);
    // A real curl: the free end has turned.
    EXPECT_GT(std::abs(ExtentAngle(solver.positions(), mesh)), 40.0) << amount;
    for (int v : bc.vertices) {
      EXPECT_EQ((solver.positions().col(v) - mesh.vertices.col(v)).norm(), 0.0);
    }
  }
}

// A bar curled at 0.99 (the fibres above its middle contract to 1%): below the handover
// force the exact K stays indefinite, and projected steps crawled, one factorization
// each (49 factorizations; the solver review of 2026-12-07). Newton hands back to
// L-BFGS after QuasistaticSolver::kProjectedStepsBeforeLbfgs projected steps.
TEST(NewtonSolverTest, AHardCurlHandsBackToLbfgsInsteadOfCrawling) {
  LatticeOptions lattice;
  lattice.nx = 40;
  lattice.ny = lattice.nz = 4;
  lattice.spacing = 0.25;
  const TetMesh mesh = MakeLatticeMesh(lattice);
  const ShapeTargetModel model(mesh, 1.0);
  BoundaryConditions bc;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) < 1e-9) bc.vertices.push_back(v);
  }
  QuasistaticSolverOptions options;
  options.ensure_stable = true;
  QuasistaticSolver solver(model, bc, options);
  ActuationMatrix a = IdentityActuations(mesh.num_tets());
  for (int e = 0; e < mesh.num_tets(); ++e) {
    double y = 0;
    for (int k = 0; k < 4; ++k) y += 0.25 * mesh.vertices(1, mesh.tets(k, e));
    a(0, e) = y > 0.5 ? 0.01 : 1.99;
  }
  solver.actuation() = a;
  const QuasistaticSolveReport report = solver.Solve();
  ASSERT_TRUE(report.converged) << report.Summary();
  EXPECT_TRUE(report.stable) << report.Summary();
  EXPECT_GE(report.newton_hand_backs, 1) << report.Summary();
  EXPECT_LE(report.newton_hand_backs, QuasistaticSolver::kMaxNewtonHandBacks);
  EXPECT_LE(report.projected_steps,
            (report.newton_hand_backs + 1) * QuasistaticSolver::kProjectedStepsBeforeLbfgs)
      << report.Summary();
  EXPECT_LE(report.factorizations, 15) << report.Summary();
  EXPECT_NE(report.Summary().find("hand-backs to L-BFGS"), std::string::npos);
}

// The hand-back itself: a projected-only solve stops after the given number of
// projected steps, not converged, and says why.
TEST(NewtonSolverTest, HandsBackAfterTheGivenProjectedSteps) {
  const TetMesh mesh = BarMesh(16, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const BoundaryConditions bc = LeftFaceFixed(mesh);
  StiffnessFactorization factorization(model, FixedVertexMask(bc, mesh.num_vertices()), 2);
  Eigen::Matrix3Xd x = mesh.vertices;
  NewtonSolverOptions options = Options(model, 1e-10);
  options.exact_force_threshold = 0.0;  // projected steps only
  options.hand_back_after_projected_steps = 3;
  const NewtonSolveReport report =
      MinimizeEnergyNewton(options, CurlActuation(mesh, 0.4), &factorization, &x);
  EXPECT_FALSE(report.converged);
  EXPECT_TRUE(report.handed_back);
  EXPECT_EQ(report.projected_steps, 3);
  EXPECT_NE(report.message.find("handed back after 3 projected steps"), std::string::npos)
      << report.message;
  EXPECT_LT(report.final_energy, report.initial_energy);
  options.hand_back_after_projected_steps = -1;
  std::string error;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error, "hand_back_after_projected_steps must be >= 0 (is -1)");
}

TEST(NewtonSolverTest, ProjectedNewtonAloneConvergesFromRest) {
  const TetMesh mesh = BarMesh(16, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const BoundaryConditions bc = LeftFaceFixed(mesh);
  StiffnessFactorization factorization(model, FixedVertexMask(bc, mesh.num_vertices()), 2);
  Eigen::Matrix3Xd x = mesh.vertices;
  const NewtonSolveReport report =
      MinimizeEnergyNewton(Options(model, 1e-10), CurlActuation(mesh, 0.4), &factorization, &x);
  ASSERT_TRUE(report.converged) << report.message;
  EXPECT_GT(report.projected_steps, 0) << "far from equilibrium at rest";
  EXPECT_GT(report.exact_steps, 0) << "exact near the end";
  EXPECT_GT(std::abs(ExtentAngle(x, mesh)), 90.0);
}

// A tolerance no solve reaches (0): at the energy's round-off floor steps by CG on an
// earlier factor can be accepted forever (the force wavering in its last digits); they
// have a budget of their own (max_reused_steps), so the solve ends within both.
TEST(NewtonSolverTest, AnUnreachableToleranceEndsWithinTheBudget) {
  const TetMesh mesh = BarMesh(16, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const BoundaryConditions bc = LeftFaceFixed(mesh);
  StiffnessFactorization factorization(model, FixedVertexMask(bc, mesh.num_vertices()), 2);
  Eigen::Matrix3Xd x = mesh.vertices;
  const ActuationMatrix a = CurlActuation(mesh, 0.4);
  ASSERT_TRUE(MinimizeEnergyNewton(Options(model, 1e-10), a, &factorization, &x).converged);
  // From the equilibrium (the factor there held for CG), on to force 0.
  NewtonSolverOptions options = Options(model, 0.0);
  options.max_factorizations = 20;
  options.max_reused_steps = 20;
  options.stall_steps = 0;  // the budgets, not the stall rule, end it
  const NewtonSolveReport report = MinimizeEnergyNewton(options, a, &factorization, &x);
  EXPECT_FALSE(report.converged) << report.message;
  EXPECT_LE(report.factorizations, 20) << report.message;
  EXPECT_LE(report.reused_steps, 20) << report.message;
  EXPECT_NE(report.message.find("limit"), std::string::npos) << report.message;
  std::printf("tolerance 0: %d exact steps (%d by CG), %d projected, %d factorizations, "
              "largest force %.3g; %s\n",
              report.exact_steps, report.reused_steps, report.projected_steps,
              report.factorizations, report.final_max_force, report.message.c_str());
}

TEST(NewtonSolverTest, ProjectedAndExactStepsReachTheSameEquilibrium) {
  const TetMesh mesh = BarMesh(8, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const BoundaryConditions bc = LeftFaceFixed(mesh);
  const ActuationMatrix a = CurlActuation(mesh, 0.2);
  StiffnessFactorization factorization(model, FixedVertexMask(bc, mesh.num_vertices()), 2);
  Eigen::Matrix3Xd hybrid = mesh.vertices, projected = mesh.vertices;
  const NewtonSolveReport report_hybrid =
      MinimizeEnergyNewton(Options(model, 1e-11), a, &factorization, &hybrid);
  NewtonSolverOptions projected_only = Options(model, 1e-9);
  projected_only.exact_force_threshold = 0.0;
  projected_only.max_factorizations = 500;
  const NewtonSolveReport report_projected =
      MinimizeEnergyNewton(projected_only, a, &factorization, &projected);
  ASSERT_TRUE(report_hybrid.converged) << report_hybrid.message;
  ASSERT_TRUE(report_projected.converged) << report_projected.message;
  EXPECT_EQ(report_projected.exact_steps, 0);
  EXPECT_LT(report_hybrid.factorizations, report_projected.factorizations)
      << "exact steps converge quadratically, projected ones linearly";
  EXPECT_LT((hybrid - projected).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(NewtonSolverTest, AgreesWithLevenbergMarquardtWhereItConverges) {
  const TetMesh mesh = BarMesh(8, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolverOptions lm;
  lm.method = EquilibriumMethod::kLevenbergMarquardt;
  lm.relative_force_tolerance = 1e-10;
  lm.max_iterations = 1000;
  QuasistaticSolverOptions newton = lm;
  newton.method = EquilibriumMethod::kNewton;
  QuasistaticSolver a(model, LeftFaceFixed(mesh), lm);
  QuasistaticSolver b(model, LeftFaceFixed(mesh), newton);
  a.actuation() = CurlActuation(mesh, 0.25);
  b.actuation() = a.actuation();
  const QuasistaticSolveReport report_a = a.Solve();
  const QuasistaticSolveReport report_b = b.Solve();
  ASSERT_TRUE(report_a.converged) << report_a.Summary();
  ASSERT_TRUE(report_b.converged) << report_b.Summary();
  EXPECT_EQ(report_b.lm_iterations, 0);
  EXPECT_LT(report_b.factorizations, report_a.iterations) << report_a.Summary() << "\n"
                                                          << report_b.Summary();
  // The same equilibrium, to 1e-6 of the bar's length (8 x 0.5).
  EXPECT_LT((a.positions() - b.positions()).cwiseAbs().maxCoeff(), 4e-6)
      << report_a.Summary() << "\n" << report_b.Summary();
}

// A 12 x 2 x 2 bar held at both ends whose fibres want to grow by 40%, slightly bent
// sideways: compressed beyond buckling, near the straight (unstable) equilibrium, where
// the exact stiffness is indefinite and the projected one is positive definite.
struct CompressedBar {
  CompressedBar() : mesh(BarMesh(12, 2, 2, 0.5)), model(mesh, 1.0) {
    const double length = mesh.vertices.row(0).maxCoeff();
    for (int v = 0; v < mesh.num_vertices(); ++v) {
      if (mesh.vertices(0, v) < 1e-9 || mesh.vertices(0, v) > length - 1e-9) bc.vertices.push_back(v);
    }
    a = IdentityActuations(mesh.num_tets());
    a.row(0).setConstant(1.4);
    bent = mesh.vertices;
    for (int v = 0; v < mesh.num_vertices(); ++v) {
      bent(1, v) += 1e-3 * std::sin(M_PI * mesh.vertices(0, v) / length);
    }
  }
  // A factorization of the bar's stiffness holding the factor of the projected K at
  // `bent`.
  std::unique_ptr<StiffnessFactorization> ProjectedFactorization() const {
    auto factorization = std::make_unique<StiffnessFactorization>(
        model, FixedVertexMask(bc, mesh.num_vertices()), 2);
    std::string error;
    EXPECT_TRUE(factorization->Factorize(bent, a, StiffnessKind::kProjected, &error)) << error;
    factorization->ResetCounters();
    return factorization;
  }
  TetMesh mesh;
  ShapeTargetModel model;
  BoundaryConditions bc;
  ActuationMatrix a;
  Eigen::Matrix3Xd bent;
};

TEST(NewtonSolverTest, IndefiniteExactStiffnessFallsBackToProjectedSteps) {
  // From a slightly bent start (no factor held) the solve must buckle the bar.
  const CompressedBar bar;
  const TetMesh& mesh = bar.mesh;
  const ShapeTargetModel& model = bar.model;
  const ActuationMatrix& a = bar.a;
  const double length = mesh.vertices.row(0).maxCoeff();
  StiffnessFactorization factorization(model, FixedVertexMask(bar.bc, mesh.num_vertices()), 2);
  std::string error;
  ASSERT_FALSE(factorization.Factorize(mesh.vertices, a, StiffnessKind::kExact, &error))
      << "the exact stiffness of the straight bar should be indefinite";
  NewtonSolverOptions options = Options(model, 1e-10);
  options.exact_force_threshold = std::numeric_limits<double>::infinity();  // exact first
  Eigen::Matrix3Xd x = bar.bent;
  const NewtonSolveReport report = MinimizeEnergyNewton(options, a, &factorization, &x);
  ASSERT_TRUE(report.converged) << report.message;
  EXPECT_GT(report.exact_rejections, 0);
  EXPECT_GT(report.projected_steps, 0);
  EXPECT_GT(report.exact_steps, 0);
  EXPECT_TRUE(factorization.Factorize(x, a, StiffnessKind::kExact, &error))
      << "a stable (buckled) equilibrium: " << error;
  // Buckled: the middle has moved sideways by a good fraction of the length.
  double sideways = 0;
  for (int v = 0; v < mesh.num_vertices(); ++v) sideways = std::max(sideways, std::abs(x(1, v) - mesh.vertices(1, v)));
  EXPECT_GT(sideways, 0.1 * length);
}

TEST(NewtonSolverTest, ExactStepsAreRetriedSoonAfterARejection) {
  // The bar buckles from the bent start: the exact K is rejected near the straight state
  // (largest force ~1e-4), the force then rises 400-fold through the buckle, and the
  // buckled equilibrium's K is positive definite. Projected steps converge there only
  // linearly (about 17% per step): had the exact K waited until the force fell below its
  // value at the rejection, the solve would have taken 30 projected steps and 32
  // factorizations. Retried after a few projected steps, it takes 8 and 11.
  const CompressedBar bar;
  StiffnessFactorization factorization(bar.model, FixedVertexMask(bar.bc, bar.mesh.num_vertices()), 2);
  NewtonSolverOptions options = Options(bar.model, 1e-10);
  options.exact_force_threshold = std::numeric_limits<double>::infinity();
  Eigen::Matrix3Xd x = bar.bent;
  const NewtonSolveReport report = MinimizeEnergyNewton(options, bar.a, &factorization, &x);
  ASSERT_TRUE(report.converged) << report.message;
  EXPECT_GT(report.exact_rejections, 0);
  EXPECT_LE(report.projected_steps, 12);
  EXPECT_LE(report.factorizations, 16);
}

// Options(model, 1e-10), with or without negative-curvature steps.
NewtonSolverOptions SaddleOptions(const ShapeTargetModel& model, bool negative_curvature,
                                  int max_factorizations) {
  NewtonSolverOptions options = Options(model, 1e-10);
  options.negative_curvature_steps = negative_curvature;
  options.max_factorizations = max_factorizations;
  return options;
}

TEST(NewtonSolverTest, NegativeCurvatureStepsLeaveASaddleInFewFactorizations) {
  // Just beyond its buckling load (fibres 1.13 times too long) the bar's straight state
  // is a saddle with a small negative curvature: from the slightly bent start, projected
  // steps leave it by a few percent per step (72 factorizations). One step along the
  // negative curvature found with the projected factor leaves it at once (6).
  CompressedBar bar;
  bar.a.row(0).setConstant(1.13);
  const std::vector<bool> fixed = FixedVertexMask(bar.bc, bar.mesh.num_vertices());
  double energies[2];
  int factorizations[2];
  for (const bool negative_curvature : {false, true}) {
    const NewtonSolverOptions options = SaddleOptions(bar.model, negative_curvature, 200);
    StiffnessFactorization factorization(bar.model, fixed, 1);
    Eigen::Matrix3Xd x = bar.bent;
    const NewtonSolveReport report = MinimizeEnergyNewton(options, bar.a, &factorization, &x);
    ASSERT_TRUE(report.converged) << report.message;
    EXPECT_EQ(report.negative_curvature_steps > 0, negative_curvature);
    energies[negative_curvature] = report.final_energy;
    factorizations[negative_curvature] = report.factorizations;
    std::printf("buckled bar, negative curvature steps %s: %d factorizations, %d steps along "
                "negative curvature\n", negative_curvature ? "on" : "off",
                report.factorizations, report.negative_curvature_steps);
    std::string error;
    EXPECT_TRUE(factorization.Factorize(x, bar.a, StiffnessKind::kExact, &error))
        << "a stable (buckled) equilibrium: " << error;
  }
  EXPECT_NEAR(energies[1], energies[0], 1e-9 * energies[0]);
  EXPECT_GT(factorizations[0], 40);
  EXPECT_LE(factorizations[1], 12);
}

// A cube held on its whole boundary whose core elements (centroid within `radius` of the
// centre) have a shape target that is inverted along z (S_zz = `szz` < 0): they want to
// flip, the rest holds them, and the energy has saddles.
struct FlatteningCube {
  FlatteningCube(double szz, double radius) : mesh(BarMesh(6, 6, 6, 0.5)), model(mesh, 1.0) {
    const Eigen::Vector3d lo = mesh.vertices.rowwise().minCoeff();
    const Eigen::Vector3d hi = mesh.vertices.rowwise().maxCoeff();
    for (int v = 0; v < mesh.num_vertices(); ++v) {
      const Eigen::Vector3d p = mesh.vertices.col(v);
      if ((p - lo).minCoeff() < 1e-9 || (hi - p).minCoeff() < 1e-9) bc.vertices.push_back(v);
    }
    a = IdentityActuations(mesh.num_tets());
    const Eigen::Vector3d centre = 0.5 * (lo + hi);
    for (int e = 0; e < mesh.num_tets(); ++e) {
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (int k = 0; k < 4; ++k) c += 0.25 * mesh.vertices.col(mesh.tets(k, e));
      if ((c - centre).norm() < radius) a(2, e) = szz;
    }
  }
  TetMesh mesh;
  ShapeTargetModel model;
  BoundaryConditions bc;
  ActuationMatrix a;
};

TEST(NewtonSolverTest, NegativeCurvatureStepsReachMinimaNotSaddles) {
  // From rest, exact steps by CG on an earlier factor converge to a saddle (CG need not
  // meet its negative curvature), which without negative-curvature steps the solve
  // reports as converged (force tolerance reached), and from which a warm re-solve for
  // slightly changed targets crawls (not converged in 100 factorizations). With them the
  // solve from rest ends at a stable equilibrium of lower energy, and the warm re-solve
  // takes a few factorizations.
  const FlatteningCube cube(-0.3, 1.2);
  const FlatteningCube changed(-0.28, 1.2);
  const std::vector<bool> fixed = FixedVertexMask(cube.bc, cube.mesh.num_vertices());
  double energies[2];
  for (const bool negative_curvature : {false, true}) {
    const NewtonSolverOptions options = SaddleOptions(cube.model, negative_curvature, 100);
    StiffnessFactorization factorization(cube.model, fixed, 1);
    Eigen::Matrix3Xd x = cube.mesh.vertices;
    const NewtonSolveReport from_rest = MinimizeEnergyNewton(options, cube.a, &factorization, &x);
    ASSERT_TRUE(from_rest.converged) << from_rest.message;
    energies[negative_curvature] = from_rest.final_energy;
    std::string error;
    EXPECT_EQ(factorization.Factorize(x, cube.a, StiffnessKind::kExact, &error),
              negative_curvature)
        << "the end of the solve from rest should be a saddle without negative-curvature "
           "steps, and stable with them";
    StiffnessFactorization warm_factorization(cube.model, fixed, 1);
    const NewtonSolveReport warm =
        MinimizeEnergyNewton(options, changed.a, &warm_factorization, &x);
    EXPECT_EQ(warm.converged, negative_curvature) << warm.message;
    if (negative_curvature) {
      EXPECT_LE(warm.factorizations, 12);
    }
  }
  EXPECT_LT(energies[1], energies[0] - 1e-3);
}

TEST(NewtonSolverTest, ConjugateGradientsReportAnIndefiniteStiffness) {
  const CompressedBar bar;
  const std::unique_ptr<StiffnessFactorization> held = bar.ProjectedFactorization();
  StiffnessFactorization& factorization = *held;
  std::string error;
  // The right-hand side K_projected v for v the exact K's eigenvector of its smallest
  // (negative) eigenvalue: the preconditioned first CG direction is v itself.
  const Eigen::MatrixXd projected = DenseFromUpperCsc(factorization.pattern(), factorization.values());
  factorization.Assemble(bar.bent, bar.a, StiffnessKind::kExact);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(
      DenseFromUpperCsc(factorization.pattern(), factorization.values()));
  ASSERT_LT(eigen.eigenvalues()[0], 0.0);
  const Eigen::VectorXd v = eigen.eigenvectors().col(0);
  const Eigen::MatrixXd b = projected * v;
  FactorReuseOptions reuse;
  Eigen::MatrixXd x;
  EXPECT_FALSE(factorization.SolveReusingFactor(b, reuse, &x));
  EXPECT_TRUE(factorization.last_reuse_found_indefinite());
  EXPECT_EQ(factorization.counters().failed_reuses, 1);
  EXPECT_EQ(factorization.counters().indefinite_reuses, 1);
  // SolveAssembled gives up at once: no factorization of a K known to be indefinite.
  EXPECT_FALSE(factorization.SolveAssembled(b, reuse, &x, &error));
  EXPECT_NE(error.find("not positive definite"), std::string::npos) << error;
  EXPECT_EQ(factorization.counters().factorizations, 0);
  EXPECT_EQ(factorization.counters().indefinite_reuses, 2);
  // ... which the factorization confirms.
  EXPECT_FALSE(factorization.FactorizeAssembled(0.0, &error));
  // A CG that gives up for slow convergence proves nothing.
  ASSERT_TRUE(factorization.Factorize(bar.bent, bar.a, StiffnessKind::kProjected, &error)) << error;
  factorization.Assemble(bar.mesh.vertices, IdentityActuations(bar.mesh.num_tets()),
                         StiffnessKind::kExact);
  reuse.max_iterations = 1;
  EXPECT_FALSE(factorization.SolveReusingFactor(b, reuse, &x));
  EXPECT_FALSE(factorization.last_reuse_found_indefinite());
  EXPECT_EQ(factorization.counters().indefinite_reuses, 2);
}

TEST(NewtonSolverTest, IndefiniteStiffnessFoundByCgCostsNoFactorization) {
  // The exact step is tried first (threshold infinity) by CG on the held factor of the
  // projected K; CG meets the buckling mode, so the exact K is rejected without a
  // factorization and the one factorization allowed goes to the projected step.
  const CompressedBar bar;
  const std::unique_ptr<StiffnessFactorization> held = bar.ProjectedFactorization();
  StiffnessFactorization& factorization = *held;
  NewtonSolverOptions options = Options(bar.model, 1e-10);
  options.exact_force_threshold = std::numeric_limits<double>::infinity();
  options.max_factorizations = 1;
  Eigen::Matrix3Xd x = bar.bent;
  const NewtonSolveReport report = MinimizeEnergyNewton(options, bar.a, &factorization, &x);
  EXPECT_EQ(factorization.counters().indefinite_reuses, 1);
  EXPECT_EQ(report.exact_rejections, 1);
  EXPECT_EQ(report.factorizations, 1);
  EXPECT_EQ(factorization.counters().factorizations, 1);
  EXPECT_EQ(report.projected_steps, 1) << report.message;
  EXPECT_LT(report.final_energy, report.initial_energy);
  // Allowed to go on, it buckles the bar, as from a start with no factor held.
  options.max_factorizations = 100;
  const NewtonSolveReport rest = MinimizeEnergyNewton(options, bar.a, &factorization, &x);
  ASSERT_TRUE(rest.converged) << rest.message;
  std::string error;
  EXPECT_TRUE(factorization.Factorize(x, bar.a, StiffnessKind::kExact, &error)) << error;
}

TEST(NewtonSolverTest, ShiftsASingularProjectedStiffness) {
  // A free body: its stiffness has six zero modes (rigid motions), so the projected
  // stiffness needs a diagonal shift. The solve must not crash and must end finite.
  const TetMesh mesh = BarMesh(3, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const std::vector<bool> none(mesh.num_vertices(), false);
  StiffnessFactorization factorization(model, none, 2);
  factorization.Assemble(mesh.vertices, testing::SmoothActuation(mesh, 0.2),
                         StiffnessKind::kProjected);
  std::string error;
  EXPECT_TRUE(factorization.FactorizeAssembled(1e-6, &error)) << error;
  NewtonSolverOptions options = Options(model, 1e-8);
  options.exact_force_threshold = 0.0;
  options.max_factorizations = 50;
  Eigen::Matrix3Xd x = mesh.vertices;
  const NewtonSolveReport report =
      MinimizeEnergyNewton(options, testing::SmoothActuation(mesh, 0.2), &factorization, &x);
  EXPECT_TRUE(x.allFinite());
  EXPECT_FALSE(report.message.empty());
  EXPECT_LT(report.final_energy, report.initial_energy);
}

// A cone pinning one vertex: E = c + k |x_v - p|, whose gradient k (x_v - p) / |x_v - p|
// jumps at p (a kink of the energy, as a contact switching on and off makes one). Its
// Hessian k (I - u u^T) / |x_v - p| is positive semi-definite (both kinds). The constant
// c stands for the energy of the rest of a large system: it sets the energy's round-off.
class ConeTerm : public EnergyTerm {
 public:
  ConeTerm(int vertex, const Eigen::Vector3d& apex, double k, double c)
      : vertex_(vertex), apex_(apex), k_(k), c_(c) {}

  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override {
    const Eigen::Vector3d d = x.col(vertex_) - apex_;
    const double r = d.norm();
    if (r > 0.0) gradient->col(vertex_) += k_ * d / r;
    return c_ + k_ * r;
  }
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x, const StiffnessPattern& pattern,
                    StiffnessKind /*kind*/, std::vector<double>* values) const override {
    const Eigen::Vector3d d = x.col(vertex_) - apex_;
    const double r = d.norm();
    if (!(r > 0.0)) return;
    const Eigen::Vector3d u = d / r;
    const Eigen::MatrixXd hessian = k_ / r * (Eigen::Matrix3d::Identity() - u * u.transpose());
    AddVertexHessian({vertex_}, hessian, pattern, values);
  }
  // One residual sqrt(2 (c + k |x_v - p|)), whose Ceres cost (half its square) is E.
  void AddResidualBlocks(ceres::Problem* problem,
                         const std::vector<double*>& vertex_blocks) const override {
    problem->AddResidualBlock(new Residual(apex_, k_, c_), nullptr, vertex_blocks[vertex_]);
  }

 private:
  class Residual : public ceres::SizedCostFunction<1, 3> {
   public:
    Residual(const Eigen::Vector3d& apex, double k, double c) : apex_(apex), k_(k), c_(c) {}
    bool Evaluate(double const* const* parameters, double* residuals,
                  double** jacobians) const override {
      const Eigen::Vector3d d = Eigen::Map<const Eigen::Vector3d>(parameters[0]) - apex_;
      const double r = d.norm();
      residuals[0] = std::sqrt(2.0 * (c_ + k_ * r));
      if (jacobians != nullptr && jacobians[0] != nullptr) {
        Eigen::Map<Eigen::Vector3d> jacobian(jacobians[0]);
        if (r > 0.0 && residuals[0] > 0.0) {
          jacobian = k_ * d / (r * residuals[0]);
        } else {
          jacobian.setZero();
        }
      }
      return true;
    }

   private:
    Eigen::Vector3d apex_;
    double k_;
    double c_;
  };

  int vertex_;
  Eigen::Vector3d apex_;
  double k_;
  double c_;
};

// The curled bar with its tip (the vertex farthest from the fixed face) pinned at its rest
// position by a cone 1.5 times as strong as the bar's pull on the tip held there, in a
// system of energy `constant` more; `start` is the rest state with the tip moved off the
// apex.
struct ConePinnedBar {
  explicit ConePinnedBar(double constant = 1e4)
      : mesh(BarMesh(16, 2, 2, 0.5)),
        model(mesh, 1.0),
        bc(LeftFaceFixed(mesh)),
        a(CurlActuation(mesh, 0.4)),
        tip(FarthestVertex(mesh)),
        pull(PullAtRest(mesh, model, bc, a, tip)),
        cone(tip, mesh.vertices.col(tip), 1.5 * pull, constant),
        start(mesh.vertices) {
    start.col(tip) += Eigen::Vector3d(0.01, 0.02, -0.01);
  }
  // A QuasistaticSolver's solve from `start`, with the cone as its energy term.
  QuasistaticSolveReport Solve(const QuasistaticSolverOptions& options) const {
    QuasistaticSolver solver(model, bc, options);
    solver.actuation() = a;
    solver.AddEnergyTerm(&cone);
    solver.SetPositions(start);
    return solver.Solve();
  }
  static int FarthestVertex(const TetMesh& mesh) {
    int tip = 0;
    for (int v = 1; v < mesh.num_vertices(); ++v) {
      if (mesh.vertices.col(v).sum() > mesh.vertices.col(tip).sum()) tip = v;
    }
    return tip;
  }
  static double PullAtRest(const TetMesh& mesh, const ShapeTargetModel& model,
                           const BoundaryConditions& bc, const ActuationMatrix& a, int vertex) {
    StiffnessFactorization factorization(model, FixedVertexMask(bc, mesh.num_vertices()), 1);
    Eigen::Matrix3Xd gradient;
    factorization.EnergyAndGradient(mesh.vertices, a, &gradient);
    return gradient.col(vertex).norm();
  }
  TetMesh mesh;
  ShapeTargetModel model;
  BoundaryConditions bc;
  ActuationMatrix a;
  int tip;
  double pull;
  ConeTerm cone;
  Eigen::Matrix3Xd start;
};

// Newton at a kink: the minimum is at the cone's apex, where the force on the pinned
// vertex cannot fall below the cone's pull minus the bar's. Exact steps toward it shrink
// and the force wavers; without the stall test the solve spends its whole budget (200
// factorizations here). It must stop early, not converged, saying so.
TEST(NewtonSolverTest, AKinkOfTheEnergyStopsTheSolveEarly) {
  const ConePinnedBar bar;
  ASSERT_GT(bar.pull, 0.0);
  StiffnessFactorization factorization(bar.model,
                                       FixedVertexMask(bar.bc, bar.mesh.num_vertices()), 2);
  factorization.set_energy_terms({&bar.cone});
  NewtonSolverOptions options = Options(bar.model, 1e-10);
  options.max_factorizations = 200;
  options.exact_force_threshold = bar.model.force_scale();  // exact steps near the kink
  Eigen::Matrix3Xd x = bar.start;
  const NewtonSolveReport report = MinimizeEnergyNewton(options, bar.a, &factorization, &x);
  std::printf("cone: %d exact, %d projected steps, %d factorizations, largest force %.3g "
              "(pull %.3g); %s\n",
              report.exact_steps, report.projected_steps, report.factorizations,
              report.final_max_force, bar.pull, report.message.c_str());
  EXPECT_FALSE(report.converged);
  EXPECT_TRUE(report.stalled) << report.message;
  EXPECT_NE(report.message.find("stalled"), std::string::npos) << report.message;
  EXPECT_LT(report.factorizations, 100) << report.message;
  EXPECT_LT(report.final_energy, report.initial_energy);
  // It stopped at the kink: the tip at the apex.
  EXPECT_LT((x.col(bar.tip) - bar.mesh.vertices.col(bar.tip)).norm(), 1e-3);
}

// The rule does not lean on the energy's size: the bar alone (its own energy, about
// 0.06 here) and in systems of energy 1e4 and 1e8 stops at the kink early (the energy
// test's 1e-10 of its value is a different amount in each).
TEST(NewtonSolverTest, AKinkStopsTheSolveWhateverTheEnergysSize) {
  for (const double constant : {0.0, 1e4, 1e8}) {
    const ConePinnedBar bar(constant);
    StiffnessFactorization factorization(bar.model,
                                         FixedVertexMask(bar.bc, bar.mesh.num_vertices()), 2);
    factorization.set_energy_terms({&bar.cone});
    NewtonSolverOptions options = Options(bar.model, 1e-10);
    options.max_factorizations = 200;
    options.exact_force_threshold = bar.model.force_scale();
    Eigen::Matrix3Xd x = bar.start;
    const NewtonSolveReport report = MinimizeEnergyNewton(options, bar.a, &factorization, &x);
    std::printf("cone in a system of energy %g more: %d factorizations, largest force %.3g; "
                "%s\n", constant, report.factorizations, report.final_max_force,
                report.message.c_str());
    EXPECT_FALSE(report.converged) << constant << ": " << report.message;
    // Stalled, or (the bar alone, whose energy's 1e-10 is a smaller amount, so more
    // tiny decreases count as progress) at the energy's round-off floor first.
    EXPECT_TRUE(report.stalled || report.message.find("round-off") != std::string::npos)
        << constant << ": " << report.message;
    EXPECT_LT(report.factorizations, 50) << constant << ": " << report.message;
    EXPECT_LT((x.col(bar.tip) - bar.mesh.vertices.col(bar.tip)).norm(), 1e-3) << constant;
  }
}

// An energy term with no stiffness, for Newton solves alone (which build no Ceres
// problem).
class StiffnessFreeTerm : public EnergyTerm {
 public:
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& /*x*/,
                    const StiffnessPattern& /*pattern*/, StiffnessKind /*kind*/,
                    std::vector<double>* /*values*/) const override {}
  void AddResidualBlocks(ceres::Problem* /*problem*/,
                         const std::vector<double*>& /*vertex_blocks*/) const override {
    ADD_FAILURE() << "Newton solves do not build a Ceres problem";
  }
};

// A kink across a plane through one vertex: E = k |n . (x_v - p)|, n a unit normal. Its
// gradient k sign(n . (x_v - p)) n jumps at the plane and its Hessian is zero: where the
// rest of the system curves down, the exact K stays indefinite at the kink.
class PlaneKinkTerm : public StiffnessFreeTerm {
 public:
  PlaneKinkTerm(int vertex, const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                double k)
      : vertex_(vertex), point_(point), normal_(normal.normalized()), k_(k) {}
  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override {
    const double s = normal_.dot(x.col(vertex_) - point_);
    if (s != 0.0) gradient->col(vertex_) += (s > 0.0 ? k_ : -k_) * normal_;
    return k_ * std::abs(s);
  }

 private:
  int vertex_;
  Eigen::Vector3d point_;
  Eigen::Vector3d normal_;
  double k_;
};

// A kink where the exact stiffness is indefinite: the buckling bar of
// NegativeCurvatureStepsLeaveASaddleInFewFactorizations with a vertex at the middle of
// its length held sideways (in y, the way the start bends) by a plane kink where it
// stands, straight. The kink holds the middle but adds no stiffness, so the exact K stays
// indefinite there: every retry of an exact step is rejected and searches for the
// negative curvature (relative -2e-4), but no step along it lowers the energy (the kink's
// cost grows linearly, the bar's gain quadratically), and projected steps crawl at the
// kink. With steps along negative curvature on, the solve must still stop early by the
// stall rule; without the rule it spends its whole budget.
TEST(NewtonSolverTest, AKinkWithNegativeCurvatureStopsTheSolveEarly) {
  CompressedBar bar;
  bar.a.row(0).setConstant(1.13);
  const double length = bar.mesh.vertices.row(0).maxCoeff();
  int middle = 0;
  for (int v = 1; v < bar.mesh.num_vertices(); ++v) {
    const auto distance = [&](int u) {
      return (bar.mesh.vertices.col(u) - Eigen::Vector3d(0.5 * length, 1.0, 1.0)).norm();
    };
    if (distance(v) < distance(middle)) middle = v;
  }
  const PlaneKinkTerm kink(middle, bar.mesh.vertices.col(middle), Eigen::Vector3d::UnitY(),
                           0.01 * bar.model.force_scale());
  const std::vector<bool> fixed = FixedVertexMask(bar.bc, bar.mesh.num_vertices());
  int factorizations[2];
  for (const int stall_steps : {16, 0}) {
    StiffnessFactorization factorization(bar.model, fixed, 2);
    factorization.set_energy_terms({&kink});
    NewtonSolverOptions options = SaddleOptions(bar.model, true, 200);
    options.exact_force_threshold = std::numeric_limits<double>::infinity();
    options.stall_steps = stall_steps;
    Eigen::Matrix3Xd x = bar.bent;
    const NewtonSolveReport report = MinimizeEnergyNewton(options, bar.a, &factorization, &x);
    std::printf("plane kink on the buckling bar, stall_steps %d: %d factorizations, %d exact "
                "rejections, %d projected, %d along negative curvature, largest force %.3g; "
                "%s\n", stall_steps, report.factorizations, report.exact_rejections,
                report.projected_steps, report.negative_curvature_steps, report.final_max_force,
                report.message.c_str());
    factorizations[stall_steps > 0] = report.factorizations;
    EXPECT_FALSE(report.converged) << report.message;
    EXPECT_GT(report.exact_rejections, 1) << report.message;  // retries: searches ran
    EXPECT_EQ(report.stalled, stall_steps > 0) << report.message;
    EXPECT_LT(report.final_energy, report.initial_energy);
    EXPECT_LT(std::abs(x(1, middle) - bar.mesh.vertices(1, middle)), 1e-3);
  }
  EXPECT_LT(factorizations[1], 100);
  EXPECT_EQ(factorizations[0], 200);
}

// A spring pulling one vertex to p, E = k/2 |x_v - p|^2, whose stiffness understates its
// Hessian as k / (2 + 1e-4) I (both kinds): the Newton step overshoots p to 1 + 1e-4 times
// the distance on the other side, raising the energy by about 2e-4 of it, which is less
// than armijo x |slope| (1e-4 x 2k|x_v - p|^2) but still a rise.
class OverstepSpringTerm : public StiffnessFreeTerm {
 public:
  OverstepSpringTerm(int vertex, const Eigen::Vector3d& p, double k)
      : vertex_(vertex), p_(p), k_(k) {}
  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override {
    const Eigen::Vector3d d = x.col(vertex_) - p_;
    gradient->col(vertex_) += k_ * d;
    return 0.5 * k_ * d.squaredNorm();
  }
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& /*x*/,
                    const StiffnessPattern& pattern, StiffnessKind /*kind*/,
                    std::vector<double>* values) const override {
    const Eigen::MatrixXd hessian = k_ / (2.0 + 1e-4) * Eigen::Matrix3d::Identity();
    AddVertexHessian({vertex_}, hessian, pattern, values);
  }

 private:
  int vertex_;
  Eigen::Vector3d p_;
  double k_;
};

// The line search takes a step only where the energy falls by the Armijo fraction of
// the slope: the spring's overstepping unit step raises the energy and is refused, and
// half of it (at p, to 1e-4 of the distance) is taken. The bar itself is nearly
// weightless (mu 1e-9) and at rest.
TEST(NewtonSolverTest, TheLineSearchRefusesAUnitStepThatRaisesTheEnergy) {
  const TetMesh mesh = BarMesh(4, 1, 1, 0.5);
  const ShapeTargetModel model(mesh, 1e-9);
  const BoundaryConditions bc = LeftFaceFixed(mesh);
  int tip = 0;
  for (int v = 1; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) > mesh.vertices(0, tip)) tip = v;
  }
  const Eigen::Vector3d p = mesh.vertices.col(tip) + Eigen::Vector3d(0.0, 0.1, 0.0);
  const OverstepSpringTerm spring(tip, p, 1.0);
  StiffnessFactorization factorization(model, FixedVertexMask(bc, mesh.num_vertices()), 1);
  factorization.set_energy_terms({&spring});
  NewtonSolverOptions options;
  options.force_tolerance = 1e-14;
  options.max_factorizations = 1;
  Eigen::Matrix3Xd x = mesh.vertices;
  const NewtonSolveReport report =
      MinimizeEnergyNewton(options, IdentityActuations(mesh.num_tets()), &factorization, &x);
  EXPECT_LT(report.final_energy, 1e-3 * report.initial_energy) << report.message;
  EXPECT_LT((x.col(tip) - p).norm(), 1e-3 * 0.1) << report.message;
  EXPECT_GE(report.energy_evaluations, 2) << "the unit step was refused";
}

// QuasistaticSolverOptions::newton_stall_steps reaches the Newton phase: the cone-pinned
// bar stalls with the default and runs to its factorization budget with 0.
TEST(NewtonSolverTest, TheQuasistaticSolverPassesItsStallSteps) {
  const ConePinnedBar bar;
  for (const int stall_steps : {16, 0}) {
    QuasistaticSolverOptions options;
    options.relative_force_tolerance = 1e-10;
    options.max_iterations = 120;
    options.newton_stall_steps = stall_steps;
    // Newton from the start, exact steps below the force scale (as in
    // AKinkOfTheEnergyStopsTheSolveEarly; L-BFGS first finds a smooth equilibrium off the
    // apex, where the bar pulls as hard as the cone).
    options.max_lbfgs_iterations = 0;
    options.newton_relative_force = 1.0;
    const QuasistaticSolveReport report = bar.Solve(options);
    std::printf("quasistatic solve at a kink, newton_stall_steps %d: %s\n", stall_steps,
                report.Summary().c_str());
    EXPECT_FALSE(report.converged) << report.Summary();
    EXPECT_EQ(report.newton_stalled, stall_steps > 0) << report.Summary();
    if (stall_steps > 0) {
      EXPECT_LT(report.iterations, 60) << report.Summary();
    } else {
      EXPECT_EQ(report.iterations, options.max_iterations) << report.Summary();
    }
  }
}

// The Levenberg-Marquardt path (a warm start's Newton phase, then Ceres, then Newton
// again, then Ceres to the end) ends where its Newton phase stalls: neither method gets
// past the kink, and before 2026-12-06 the next phases spent the rest of the budget.
TEST(NewtonSolverTest, AStalledNewtonPhaseEndsALevenbergMarquardtSolve) {
  const ConePinnedBar bar;
  QuasistaticSolverOptions options;
  options.method = EquilibriumMethod::kLevenbergMarquardt;
  options.relative_force_tolerance = 1e-10;
  options.newton_relative_force = 10.0;  // the start is warm enough for Newton
  options.max_iterations = 200;
  const QuasistaticSolveReport report = bar.Solve(options);
  std::printf("LM path at a kink: %s\n", report.Summary().c_str());
  EXPECT_FALSE(report.converged);
  EXPECT_TRUE(report.newton_stalled) << report.Summary();
  EXPECT_NE(report.Path().find("(stalled)"), std::string::npos) << report.Path();
  EXPECT_EQ(report.lm_iterations, 0) << report.Summary();
  EXPECT_LT(report.factorizations, 60) << report.Summary();
}

// The energy of the rest of a large system, a constant: E = c (no force, no stiffness).
class ConstantTerm : public StiffnessFreeTerm {
 public:
  explicit ConstantTerm(double c) : c_(c) {}
  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& /*x*/,
                              Eigen::Matrix3Xd* /*gradient*/) const override {
    return c_;
  }

 private:
  double c_;
};

// Leaving a saddle by projected steps looks like a stall to a rule that only asks for
// progress: the force grows step after step, and the energy falls by an amount that does
// not grow with the system, below 1e-10 of a large energy. Those are full steps, which
// the rule takes for progress: the buckling bar of
// NegativeCurvatureStepsLeaveASaddleInFewFactorizations, in a system whose energy is
// 1e6, leaves its saddle by projected steps alone and converges.
TEST(NewtonSolverTest, ASaddleEscapeByProjectedStepsDoesNotStall) {
  CompressedBar bar;
  bar.a.row(0).setConstant(1.13);
  StiffnessFactorization factorization(bar.model,
                                       FixedVertexMask(bar.bc, bar.mesh.num_vertices()), 1);
  const ConstantTerm rest_of_system(1e6);
  factorization.set_energy_terms({&rest_of_system});
  Eigen::Matrix3Xd x = bar.bent;
  const NewtonSolveReport report =
      MinimizeEnergyNewton(SaddleOptions(bar.model, false, 200), bar.a, &factorization, &x);
  std::printf("saddle escape at energy 1e6: %d projected, %d exact steps, %d factorizations; "
              "%s\n", report.projected_steps, report.exact_steps, report.factorizations,
              report.message.c_str());
  EXPECT_TRUE(report.converged) << report.message;
  EXPECT_FALSE(report.stalled) << report.message;
}

// A smooth solve never stalls: the curled bar reaches a tight tolerance.
TEST(NewtonSolverTest, ASmoothSolveDoesNotStall) {
  const TetMesh mesh = BarMesh(16, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const BoundaryConditions bc = LeftFaceFixed(mesh);
  StiffnessFactorization factorization(model, FixedVertexMask(bc, mesh.num_vertices()), 2);
  for (double amount : {0.25, 0.4}) {
    Eigen::Matrix3Xd x = mesh.vertices;
    const NewtonSolveReport report = MinimizeEnergyNewton(
        Options(model, 1e-12), CurlActuation(mesh, amount), &factorization, &x);
    EXPECT_TRUE(report.converged) << amount << ": " << report.message;
    EXPECT_FALSE(report.stalled) << amount;
  }
}

TEST(NewtonSolverTest, RefusesFreeBodiesAndNonFiniteActuations) {
  const TetMesh mesh = BarMesh(3, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolver free_body(model, BoundaryConditions());
  free_body.actuation() = testing::SmoothActuation(mesh, 0.2);
  const QuasistaticSolveReport refused = free_body.Solve();
  EXPECT_FALSE(refused.converged);
  EXPECT_NE(refused.termination.find("no fixed vertex"), std::string::npos) << refused.Summary();
  EXPECT_EQ(refused.factorizations, 0);

  QuasistaticSolver solver(model, LeftFaceFixed(mesh));
  solver.actuation() = testing::SmoothActuation(mesh, 0.2);
  solver.actuation()(3, 7) = std::numeric_limits<double>::quiet_NaN();
  const QuasistaticSolveReport nan = solver.Solve();
  EXPECT_FALSE(nan.converged);
  EXPECT_NE(nan.termination.find("element 7 is not finite"), std::string::npos) << nan.Summary();
}

TEST(NewtonSolverTest, OptionsAreValidated) {
  std::string error;
  NewtonSolverOptions options;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.force_tolerance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("force_tolerance"), std::string::npos);
  options = NewtonSolverOptions();
  options.max_factorizations = 0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("max_factorizations"), std::string::npos);
  options = NewtonSolverOptions();
  options.stall_steps = -1;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("stall_steps"), std::string::npos);
  QuasistaticSolverOptions solver;
  EXPECT_TRUE(solver.Validate(&error)) << error;
  solver.relative_force_tolerance = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(solver.Validate(&error));
  EXPECT_NE(error.find("relative_force_tolerance"), std::string::npos);
  solver = QuasistaticSolverOptions();
  solver.newton_relative_force = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(solver.Validate(&error));
  EXPECT_NE(error.find("newton_relative_force"), std::string::npos);
  solver = QuasistaticSolverOptions();
  solver.newton_stall_steps = -1;
  EXPECT_FALSE(solver.Validate(&error));
  EXPECT_NE(error.find("newton_stall_steps"), std::string::npos);
  // The default stall rule leaves the key as it was before the option (stored results
  // still match); another value changes it.
  solver = QuasistaticSolverOptions();
  EXPECT_EQ(solver.KeyText().find("stall"), std::string::npos) << solver.KeyText();
  const std::string default_key = solver.KeyText();
  solver.newton_stall_steps = 0;
  EXPECT_NE(solver.KeyText(), default_key);
}

TEST(NewtonSolverTest, FactorOfANearbyStateSolvesByConjugateGradients) {
  const TetMesh mesh = BarMesh(8, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const BoundaryConditions bc = LeftFaceFixed(mesh);
  QuasistaticSolver solver(model, bc);
  solver.actuation() = CurlActuation(mesh, 0.2);
  ASSERT_TRUE(solver.Solve().converged);
  StiffnessFactorization factorization(model, FixedVertexMask(bc, mesh.num_vertices()), 2);
  std::string error;
  ASSERT_TRUE(factorization.Factorize(solver.positions(), solver.actuation(), StiffnessKind::kExact,
                                      &error));
  // K at a nearby state (the actuation changed by 1%), solved with the old factor.
  const ActuationMatrix changed = IdentityActuations(mesh.num_tets()) +
                                  1.01 * (solver.actuation() - IdentityActuations(mesh.num_tets()));
  factorization.Assemble(solver.positions(), changed, StiffnessKind::kExact);
  EXPECT_FALSE(factorization.factor_current());
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd b(factorization.pattern().num_dofs(), 1);
  for (int i = 0; i < b.rows(); ++i) b(i, 0) = normal(rng);
  const Eigen::MatrixXd k =
      DenseFromUpperCsc(factorization.pattern(), factorization.values());
  // MultiplyAssembled is K v.
  EXPECT_LT((factorization.MultiplyAssembled(b.col(0)) - k * b.col(0)).norm(),
            1e-12 * (k * b.col(0)).norm());
  FactorReuseOptions reuse;
  reuse.relative_tolerance = 1e-10;
  Eigen::MatrixXd x;
  ASSERT_TRUE(factorization.SolveReusingFactor(b, reuse, &x));
  EXPECT_LE((k * x - b).norm(), 1e-10 * b.norm() * 1.0001);
  EXPECT_EQ(factorization.counters().reused_solves, 1);
  EXPECT_EQ(factorization.counters().factorizations, 1);
  EXPECT_GT(factorization.counters().cg_iterations, 0);
  EXPECT_LE(factorization.counters().cg_iterations, 8) << "a 1% change: a few iterations";
  // Another actuation, and too few iterations allowed: CG gives up, SolveAssembled
  // factorizes.
  factorization.Assemble(solver.positions(), CurlActuation(mesh, -0.3), StiffnessKind::kProjected);
  reuse.max_iterations = 2;
  EXPECT_FALSE(factorization.SolveReusingFactor(b, reuse, &x));
  EXPECT_EQ(factorization.counters().failed_reuses, 1);
  ASSERT_TRUE(factorization.SolveAssembled(b, reuse, &x, &error)) << error;
  EXPECT_TRUE(factorization.factor_current());
  const Eigen::MatrixXd k_far = DenseFromUpperCsc(factorization.pattern(), factorization.values());
  EXPECT_LT((k_far * x - b).norm(), 1e-9 * b.norm());
  EXPECT_EQ(factorization.counters().factorizations, 2);
  // A shifted factor is not K's: SolveAssembled still solves with K itself (by CG on
  // the shifted factor, or by factorizing K), never with K + shift.
  ASSERT_TRUE(factorization.FactorizeAssembled(1e-2, &error)) << error;
  EXPECT_FALSE(factorization.factor_current());
  reuse.max_iterations = 50;
  ASSERT_TRUE(factorization.SolveAssembled(b, reuse, &x, &error)) << error;
  EXPECT_LT((k_far * x - b).norm(), 1e-9 * b.norm());
}

// The 8 x 2 x 2 bar fixed at its left face, curled by CurlActuation(0.2) and solved to a
// relative force of 1e-10, for the warm re-solves below; Scaled() is its actuation's
// deformation scaled by 1.01 (a nearby state).
class CurledBarTest : public ::testing::Test {
 protected:
  CurledBarTest() : mesh_(BarMesh(8, 2, 2, 0.5)), model_(mesh_, 1.0) {
    options_.relative_force_tolerance = 1e-10;
  }
  // A solver with options_, solved at CurlActuation(amount).
  std::unique_ptr<QuasistaticSolver> Curled(double amount) {
    auto solver = std::make_unique<QuasistaticSolver>(model_, LeftFaceFixed(mesh_), options_);
    solver->actuation() = CurlActuation(mesh_, amount);
    EXPECT_TRUE(solver->Solve().converged);
    return solver;
  }
  // The equilibrium under `actuation` solved from `start` with a factorization at every
  // Newton step (no factor reuse), for reference.
  Eigen::Matrix3Xd FreshlySolved(const ActuationMatrix& actuation, const Eigen::Matrix3Xd& start) {
    QuasistaticSolverOptions fresh = options_;
    fresh.factor_reuse.max_iterations = 0;
    QuasistaticSolver reference(model_, LeftFaceFixed(mesh_), fresh);
    reference.actuation() = actuation;
    reference.SetPositions(start);
    EXPECT_TRUE(reference.Solve().converged);
    return reference.positions();
  }
  // Solves `solver` (warm) and expects every Newton step on the factor it holds (by CG,
  // no factorization) and the equilibrium of a fresh solve from `start`.
  void ExpectSolvedOnTheHeldFactor(QuasistaticSolver* solver, const Eigen::Matrix3Xd& start) {
    const QuasistaticSolveReport warm = solver->Solve();
    ASSERT_TRUE(warm.converged) << warm.Summary();
    EXPECT_GT(warm.reused_steps, 0) << warm.Summary();
    EXPECT_EQ(warm.factorizations, 0) << warm.Summary();
    EXPECT_LT((FreshlySolved(solver->actuation(), start) - solver->positions()).cwiseAbs().maxCoeff(),
              1e-8);
  }
  ActuationMatrix Scaled(const QuasistaticSolver& solver) const {
    const ActuationMatrix identity = IdentityActuations(mesh_.num_tets());
    return identity + 1.01 * (ActuationMatrix(solver.actuation()) - identity);
  }
  TetMesh mesh_;
  ShapeTargetModel model_;
  QuasistaticSolverOptions options_;
};

TEST_F(CurledBarTest, WarmResolveReusesTheFactor) {
  std::unique_ptr<QuasistaticSolver> solver = Curled(0.2);
  const Eigen::Matrix3Xd first = solver->positions();
  solver->actuation() = Scaled(*solver);
  ExpectSolvedOnTheHeldFactor(solver.get(), first);
}

// A solver shared between poses marks the factor it holds as another system's
// (RequestRefresh): the next solve factorizes first, and its later steps reuse that new
// factor by CG. (Without the request the same warm solve factorizes nothing:
// WarmResolveReusesTheFactor.)
TEST_F(CurledBarTest, RequestedRefreshFactorizesOnceThenReuses) {
  std::unique_ptr<QuasistaticSolver> solver = Curled(0.2);
  solver->actuation() = Scaled(*solver);
  solver->stiffness_factorization()->RequestRefresh();
  const QuasistaticSolveReport warm = solver->Solve();
  ASSERT_TRUE(warm.converged) << warm.Summary();
  EXPECT_EQ(warm.factorizations, 1) << warm.Summary();
  EXPECT_GT(warm.reused_steps, 0) << warm.Summary();
  EXPECT_EQ(warm.exact_steps, warm.reused_steps + 1) << warm.Summary();
}

// lbfgs_reuses_factor: the L-BFGS phase far from equilibrium is preconditioned by the
// solver's own earlier factor (no rotation-fixed factor is built: no factorization for
// it); a first solve, without one, builds the rotation-fixed factor as by default and
// releases it. Both reach the default's equilibrium.
TEST_F(CurledBarTest, LbfgsPreconditionedByTheEarlierFactor) {
  std::unique_ptr<QuasistaticSolver> reference = Curled(0.1);
  options_.lbfgs_reuses_factor = true;
  auto solver = std::make_unique<QuasistaticSolver>(model_, LeftFaceFixed(mesh_), options_);
  // No factor yet: the rotation-fixed preconditioner, as by default, then released.
  solver->actuation() = CurlActuation(mesh_, 0.1);
  const QuasistaticSolveReport first = solver->Solve();
  ASSERT_TRUE(first.converged) << first.Summary();
  EXPECT_GT(first.lbfgs_iterations, 0) << first.Summary();
  EXPECT_FALSE(solver->holds_lbfgs_preconditioner()) << "released after the first solve";
  EXPECT_TRUE(reference->holds_lbfgs_preconditioner());
  // A large change from there: L-BFGS on the earlier factor, then Newton.
  solver->actuation() = CurlActuation(mesh_, 0.3);
  const QuasistaticSolveReport far = solver->Solve();
  ASSERT_TRUE(far.converged) << far.Summary();
  EXPECT_GT(far.lbfgs_iterations, 0) << far.Summary();
  EXPECT_EQ(far.factorizations, far.exact_steps + far.projected_steps - far.reused_steps +
                                    far.shifted_factorizations)
      << "every factorization is a Newton step's: " << far.Summary();
  EXPECT_FALSE(solver->holds_lbfgs_preconditioner());
  reference->actuation() = CurlActuation(mesh_, 0.3);
  ASSERT_TRUE(reference->Solve().converged);
  EXPECT_LT((reference->positions() - solver->positions()).cwiseAbs().maxCoeff(), 1e-7);
}

// lbfgs_reused_factor_stall_iterations: an earlier factor that no longer fits the state
// (here the solver's own, refactorized with a shift of 30 mean diagonals) makes L-BFGS
// crawl; once its force has not halved in 20 iterations Newton takes over, and the solve
// converges to the same equilibrium in fewer L-BFGS iterations than without the test.
TEST_F(CurledBarTest, StalledLbfgsOnAnEarlierFactorHandsOverToNewton) {
  options_.lbfgs_reuses_factor = true;
  options_.max_lbfgs_iterations = 300;
  QuasistaticSolveReport reports[2];
  Eigen::Matrix3Xd results[2];
  for (int stall : {0, 1}) {
    options_.lbfgs_reused_factor_stall_iterations = stall ? 20 : 0;
    std::unique_ptr<QuasistaticSolver> solver = Curled(0.1);
    StiffnessFactorization* own = solver->stiffness_factorization();
    std::string error;
    own->Assemble(solver->positions(), solver->actuation(), StiffnessKind::kExact);
    ASSERT_TRUE(own->FactorizeAssembled(30.0, &error)) << error;
    solver->actuation() = CurlActuation(mesh_, 0.3);
    reports[stall] = solver->Solve();
    results[stall] = solver->positions();
    ASSERT_TRUE(reports[stall].converged) << reports[stall].Summary();
    EXPECT_EQ(reports[stall].lbfgs_stalled, stall == 1) << reports[stall].Summary();
  }
  // Without the test L-BFGS runs to its limit (then Newton, which may hand back to it).
  EXPECT_GE(reports[0].lbfgs_iterations, 300) << reports[0].Summary();
  EXPECT_NE(reports[0].termination.find("L-BFGS: iteration limit (300) reached"),
            std::string::npos)
      << reports[0].Summary();
  EXPECT_LT(reports[1].lbfgs_iterations, 100) << reports[1].Summary();
  EXPECT_NE(reports[1].Path().find("(stalled)"), std::string::npos) << reports[1].Path();
  EXPECT_LT((results[0] - results[1]).cwiseAbs().maxCoeff(), 1e-7);
}

// A solver shared between poses can keep a pose's factor (StoreFactor) and put it back
// before that pose's next solve (RestoreFactor), after solving another pose: the warm
// re-solve then reuses it by CG as if the solver had been the pose's own, and reaches
// the same equilibrium as a fresh solve.
TEST_F(CurledBarTest, RestoredFactorServesTheWarmResolve) {
  std::unique_ptr<QuasistaticSolver> solver = Curled(0.2);
  const Eigen::Matrix3Xd first = solver->positions();
  const ActuationMatrix first_actuation = solver->actuation();
  StoredStiffnessFactor stored;
  ASSERT_TRUE(solver->stiffness_factorization()->StoreFactor(&stored));
  // Another pose in between.
  solver->actuation() = CurlActuation(mesh_, -0.15);
  solver->SetPositions(mesh_.vertices);
  ASSERT_TRUE(solver->Solve().converged);
  // Back to the first pose, a little changed, with its own factor.
  solver->actuation() = first_actuation;
  solver->actuation() = Scaled(*solver);
  solver->SetPositions(first);
  ASSERT_TRUE(solver->stiffness_factorization()->RestoreFactor(stored));
  EXPECT_FALSE(solver->stiffness_factorization()->factor_current());
  ExpectSolvedOnTheHeldFactor(solver.get(), first);
  // A factor stored after it had aged makes the next solve factorize afresh.
  solver->stiffness_factorization()->RequestRefresh();
  StoredStiffnessFactor aged;
  ASSERT_TRUE(solver->stiffness_factorization()->StoreFactor(&aged));
  EXPECT_TRUE(aged.aged);
  ASSERT_TRUE(solver->stiffness_factorization()->RestoreFactor(stored));
  EXPECT_FALSE(solver->stiffness_factorization()->refresh_requested());
  ASSERT_TRUE(solver->stiffness_factorization()->RestoreFactor(aged));
  EXPECT_TRUE(solver->stiffness_factorization()->refresh_requested());
}

// CG preconditioned by a restored single-precision copy needs more iterations than with
// the exact factor, even on the matrix the copy came from; while such a copy is held,
// SolveReusingFactor allows kRoundedFactorIterations more than its options say.
TEST_F(CurledBarTest, RoundedCopyIsAllowedMoreCgIterations) {
  std::unique_ptr<QuasistaticSolver> solver = Curled(0.2);
  StiffnessFactorization& factorization = *solver->stiffness_factorization();
  std::string error;
  ASSERT_TRUE(factorization.Factorize(solver->positions(), solver->actuation(), StiffnessKind::kExact,
                                      &error))
      << error;
  FactorReuseOptions one;
  one.max_iterations = 1;
  one.probe_iterations = 0;
  one.refresh_iterations = 0;
  const Eigen::MatrixXd b = Eigen::MatrixXd::Ones(factorization.cholesky().size(), 1);
  Eigen::MatrixXd exact, rounded;
  factorization.ResetCounters();
  ASSERT_TRUE(factorization.SolveReusingFactor(b, one, &exact));
  EXPECT_EQ(factorization.counters().cg_iterations, 1);
  StoredStiffnessFactor stored;
  ASSERT_TRUE(factorization.StoreFactor(&stored));
  ASSERT_TRUE(factorization.RestoreFactor(stored));
  factorization.ResetCounters();
  ASSERT_TRUE(factorization.SolveReusingFactor(b, one, &rounded));
  EXPECT_GT(factorization.counters().cg_iterations, 1);
  EXPECT_LE(factorization.counters().cg_iterations,
            1 + StiffnessFactorization::kRoundedFactorIterations);
  EXPECT_LT((rounded - exact).norm(), 1e-8 * exact.norm());
  // A new factorization is exact again: one iteration allowed, one needed.
  factorization.Assemble(solver->positions(), solver->actuation(), StiffnessKind::kExact);
  ASSERT_TRUE(factorization.FactorizeAssembled(0.0, &error)) << error;
  factorization.ResetCounters();
  ASSERT_TRUE(factorization.SolveReusingFactor(b, one, &exact));
  EXPECT_EQ(factorization.counters().cg_iterations, 1);
}

}  // namespace
}  // namespace aqs
