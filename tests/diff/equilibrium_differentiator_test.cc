#include "diff/equilibrium_differentiator.h"

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "diff/actuation_force_products.h"
#include "equilibrium/newton_solver.h"
#include "equilibrium/quasistatic_solver.h"
#include "equilibrium/stiffness_factorization.h"
#include "physics/stiffness_assembly.h"
#include "testing/element_states.h"
#include "testing/finite_difference.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

// The equilibrium for actuation a from warm start `start`, to near round-off: the
// Ceres solve, then exact Newton refinement (FD references need ~1e-13 accuracy).
Eigen::Matrix3Xd Equilibrium(QuasistaticSolver* solver, const ActuationMatrix& a,
                             const Eigen::Matrix3Xd& start) {
  solver->actuation() = a;
  solver->SetPositions(start);
  const QuasistaticSolveReport report = solver->Solve();
  EXPECT_TRUE(report.converged) << report.Summary();
  StiffnessFactorization refiner(solver->model(), solver->fixed_mask(), 1);
  NewtonSolverOptions options;
  options.force_tolerance = 1e-13 * solver->model().force_scale();
  Eigen::Matrix3Xd x = solver->positions();
  const NewtonSolveReport refined = MinimizeEnergyNewton(options, a, &refiner, &x);
  EXPECT_TRUE(refined.converged) << refined.message << " " << refined.final_max_force;
  return x;
}

QuasistaticSolverOptions SolverOptions() {
  QuasistaticSolverOptions options;
  options.relative_force_tolerance = 1e-6;  // into Newton's basin; refinement does the rest
  options.num_threads = 1;
  return options;
}

// L(x) = 1/2 sum_v |x_v - y_v|^2 over all vertices.
double Loss(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& y) {
  return 0.5 * (x - y).squaredNorm();
}

// A bar with its left face fixed, at the equilibrium x of a smooth plus random
// actuation a, and a loss target y = x + N(0, 0.1) noise: the set-up of the adjoint
// checks. With random_mu, every element's mu is drawn from U(0.5, 2) first.
struct AdjointScene {
  TetMesh mesh;
  std::unique_ptr<ShapeTargetModel> model;
  BoundaryConditions bc;
  std::unique_ptr<QuasistaticSolver> solver;
  ActuationMatrix a;
  Eigen::Matrix3Xd x, y;
};

AdjointScene MakeAdjointScene(int nx, unsigned seed, bool random_mu) {
  AdjointScene scene;
  scene.mesh = testing::BarMesh(nx, 1, 1, 0.5);
  const TetMesh& mesh = scene.mesh;
  std::mt19937 rng(seed);
  Eigen::VectorXd mu = Eigen::VectorXd::Ones(mesh.num_tets());
  if (random_mu) {
    std::uniform_real_distribution<double> uniform_mu(0.5, 2.0);
    for (int e = 0; e < mu.size(); ++e) mu[e] = uniform_mu(rng);
  }
  scene.model = std::make_unique<ShapeTargetModel>(mesh, mu);
  scene.bc = testing::LeftFaceFixed(mesh);
  scene.solver = std::make_unique<QuasistaticSolver>(*scene.model, scene.bc, SolverOptions());
  scene.a = testing::SmoothActuation(mesh, 0.2) +
            testing::RandomActuation(mesh.num_tets(), 0.05, &rng) -
            IdentityActuations(mesh.num_tets());
  scene.x = Equilibrium(scene.solver.get(), scene.a, mesh.vertices);
  scene.y = scene.x;
  std::normal_distribution<double> normal(0.0, 0.1);
  for (int i = 0; i < scene.y.size(); ++i) scene.y.data()[i] += normal(rng);
  return scene;
}

TEST(EquilibriumDifferentiatorTest, OptionsValidateNamesTheBadField) {
  std::string error;
  EquilibriumDifferentiatorOptions options;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.reuse.max_iterations = 20;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.reuse.relative_tolerance = -1.0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("reuse.relative_tolerance", 0), 0u) << error;
  options = EquilibriumDifferentiatorOptions();
  options.num_threads = 0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("num_threads", 0), 0u) << error;
}

TEST(EquilibriumDifferentiatorTest, FullGradientMatchesResolvedEquilibria) {
  AdjointScene scene = MakeAdjointScene(2, 17, true);
  const ShapeTargetModel& model = *scene.model;
  QuasistaticSolver& solver = *scene.solver;
  const ActuationMatrix& a = scene.a;
  const Eigen::Matrix3Xd& x = scene.x;
  const Eigen::Matrix3Xd& y = scene.y;

  EquilibriumDifferentiator differentiator(model, solver.fixed_mask());
  std::string error;
  ASSERT_TRUE(differentiator.Prepare(x, a, &error)) << error;
  const ActuationMatrix analytic = differentiator.LossGradient(x - y);

  auto loss_of_actuation = [&](const Eigen::VectorXd& flat) {
    const ActuationMatrix perturbed = Eigen::Map<const ActuationMatrix>(flat.data(), 6, a.cols());
    return Loss(Equilibrium(&solver, perturbed, x), y);
  };
  const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(
      loss_of_actuation, Eigen::Map<const Eigen::VectorXd>(a.data(), a.size()), 1e-4);
  const double error_value = testing::RelativeError(
      Eigen::Map<const Eigen::VectorXd>(analytic.data(), analytic.size()), numeric);
  EXPECT_LT(error_value, 1e-5);
  EXPECT_GT(numeric.norm(), 1e-3) << "the check must not be vacuous";
  std::printf("adjoint vs re-solved equilibria: %d components, relative error %.2e\n",
              static_cast<int>(numeric.size()), error_value);
}

// At an equilibrium x of actuation a (the solver holding the model's boundary
// conditions): the adjoint's directional gradient of L = 1/2 |x - y|^2 and the Jacobian
// products for k random directions against central differences (step `step`) of
// re-solved equilibria, to a relative `tolerance`.
void ExpectProductsMatchResolvedEquilibriaAt(const ShapeTargetModel& model,
                                             QuasistaticSolver* solver, const ActuationMatrix& a,
                                             const Eigen::Matrix3Xd& x, int k, unsigned seed,
                                             double step, double tolerance) {
  std::mt19937 rng(seed);
  const Eigen::Matrix3Xd y = x + 0.05 * Eigen::Matrix3Xd::Random(3, x.cols());

  EquilibriumDifferentiator differentiator(model, solver->fixed_mask());
  std::string error;
  ASSERT_TRUE(differentiator.Prepare(x, a, &error)) << error;
  const ActuationMatrix gradient = differentiator.LossGradient(x - y);

  Eigen::MatrixXd directions(6 * model.num_elements(), k);
  for (int i = 0; i < directions.size(); ++i) {
    directions.data()[i] = std::uniform_real_distribution<double>(-1, 1)(rng);
  }
  const Eigen::MatrixXd jvp = differentiator.ActuationJacobianProduct(directions);
  ASSERT_EQ(jvp.rows(), x.size());
  for (int c = 0; c < k; ++c) {
    auto equilibrium_along = [&](const Eigen::VectorXd& t) -> Eigen::VectorXd {
      const ActuationMatrix perturbed =
          a + t[0] * Eigen::Map<const ActuationMatrix>(directions.col(c).data(), 6, a.cols());
      const Eigen::Matrix3Xd xt = Equilibrium(solver, perturbed, x);
      Eigen::VectorXd out(xt.size() + 1);
      out.head(xt.size()) = Eigen::Map<const Eigen::VectorXd>(xt.data(), xt.size());
      out[xt.size()] = Loss(xt, y);
      return out;
    };
    const Eigen::VectorXd numeric = testing::CentralDifferenceDirectional(
        equilibrium_along, Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), step);
    const double directional = Eigen::Map<const Eigen::VectorXd>(gradient.data(), gradient.size())
                                   .dot(directions.col(c));
    EXPECT_NEAR(directional, numeric[x.size()], tolerance * std::abs(numeric[x.size()]))
        << "direction " << c;
    EXPECT_LT(testing::RelativeError(jvp.col(c), numeric.head(x.size())), tolerance)
        << "direction " << c;
  }
  // Fixed vertices do not move.
  for (int v : solver->fixed_vertices()) EXPECT_EQ(jvp.block(3 * v, 0, 3, k).norm(), 0.0);
}

// The same at the equilibrium of actuation a on `mesh` (left face fixed), reached from
// rest (in *equilibrium if not null).
void ExpectProductsMatchResolvedEquilibria(const TetMesh& mesh, const ActuationMatrix& a, int k,
                                           unsigned seed, Eigen::Matrix3Xd* equilibrium = nullptr) {
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolver solver(model, testing::LeftFaceFixed(mesh), SolverOptions());
  const Eigen::Matrix3Xd x = Equilibrium(&solver, a, mesh.vertices);
  if (equilibrium != nullptr) *equilibrium = x;
  ExpectProductsMatchResolvedEquilibriaAt(model, &solver, a, x, k, seed, 1e-4, 1e-5);
}

TEST(EquilibriumDifferentiatorTest, DirectionalGradientAndJacobianProductsOnLargerBar) {
  const TetMesh mesh = testing::BarMesh(6, 3, 2, 0.3);
  ExpectProductsMatchResolvedEquilibria(mesh, testing::SmoothActuation(mesh, 0.25), 3, 19);
}

// The same far from rest: a bar curled until its free end has turned by tens of
// degrees (large rotations of every element), with random actuation on top.
TEST(EquilibriumDifferentiatorTest, ProductsMatchResolvedEquilibriaOfACurledBar) {
  const TetMesh mesh = testing::BarMesh(8, 2, 2, 0.4);
  std::mt19937 rng(23);
  const ActuationMatrix a = testing::CurlActuation(mesh, 0.4) +
                            testing::RandomActuation(mesh.num_tets(), 0.03, &rng) -
                            IdentityActuations(mesh.num_tets());
  Eigen::Matrix3Xd x;
  ExpectProductsMatchResolvedEquilibria(mesh, a, 2, 29, &x);
  // A real curl: the line from the fixed face's centre to the free face's has turned.
  const double length = mesh.vertices.row(0).maxCoeff();
  Eigen::Vector3d tip = Eigen::Vector3d::Zero(), root = Eigen::Vector3d::Zero();
  int tips = 0, roots = 0;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) > length - 1e-9) tip += x.col(v), ++tips;
    if (mesh.vertices(0, v) < 1e-9) root += x.col(v), ++roots;
  }
  const Eigen::Vector3d axis = tip / tips - root / roots;
  const double degrees = std::acos(axis.x() / axis.norm()) * 180.0 / M_PI;
  EXPECT_GT(degrees, 30.0);
  std::printf("curled bar: its axis turned by %.1f degrees\n", degrees);
}

// Near a singular stiffness: a bar held at both ends whose fibres want to be longer,
// just short of buckling, where K's smallest eigenvalue is about 1e-3 of its mean
// diagonal. Errors of the adjoint that grow as 1/lambda_min (a shift applied where
// none is needed, a loose solve) would show here, not on a well-conditioned bar.
TEST(EquilibriumDifferentiatorTest, ProductsMatchResolvedEquilibriaNearBuckling) {
  const TetMesh mesh = testing::BarMesh(12, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  BoundaryConditions bc;
  const double length = mesh.vertices.row(0).maxCoeff();
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) < 1e-9 || mesh.vertices(0, v) > length - 1e-9) bc.vertices.push_back(v);
  }
  QuasistaticSolver solver(model, bc, SolverOptions());
  StiffnessFactorization factorization(model, solver.fixed_mask(), 1);
  // The straight bar is an equilibrium at every stretch (uniform stress); its K's
  // smallest eigenvalue over the mean |diagonal| falls through 0 at buckling.
  auto relative_smallest = [&](double stretch) {
    ActuationMatrix a = IdentityActuations(mesh.num_tets());
    a.row(0).setConstant(stretch);
    factorization.Assemble(mesh.vertices, a, StiffnessKind::kExact);
    const Eigen::MatrixXd dense =
        DenseFromUpperCsc(factorization.pattern(), factorization.values());
    return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense).eigenvalues()[0] /
           dense.diagonal().cwiseAbs().mean();
  };
  double stable = 1.0, buckled = 1.4;
  ASSERT_GT(relative_smallest(stable), 1e-3);
  ASSERT_LT(relative_smallest(buckled), 0.0);
  double ratio = relative_smallest(stable);
  while (ratio > 2e-3) {  // bisect to a ratio in (0, 2e-3]
    const double middle = 0.5 * (stable + buckled);
    const double r = relative_smallest(middle);
    (r > 0 ? stable : buckled) = middle;
    if (r > 0) ratio = r;
    ASSERT_GT(buckled - stable, 1e-12);
  }
  ActuationMatrix a = IdentityActuations(mesh.num_tets());
  a.row(0).setConstant(stable);
  std::printf("near buckling: stretch %.6f, lambda_min / mean |diag K| = %.2e\n", stable, ratio);

  const Eigen::Matrix3Xd x = Equilibrium(&solver, a, mesh.vertices);
  EXPECT_LT((x - mesh.vertices).cwiseAbs().maxCoeff(), 1e-8) << "still straight";
  // Small steps: the equilibrium's curvature along the soft mode grows near buckling.
  // Measured: relative errors of 2e-10 and 9e-10.
  ExpectProductsMatchResolvedEquilibriaAt(model, &solver, a, x, 2, 41, 1e-6, 1e-7);
}

TEST(EquilibriumDifferentiatorTest, FixedVertexProductsMatchResolvedEquilibria) {
  const TetMesh mesh = testing::BarMesh(5, 2, 2, 0.3);
  const ShapeTargetModel model(mesh, 1.0);
  BoundaryConditions bc = testing::LeftFaceFixed(mesh);
  QuasistaticSolver solver(model, bc, SolverOptions());
  const ActuationMatrix a = testing::SmoothActuation(mesh, 0.2);
  const Eigen::Matrix3Xd x = Equilibrium(&solver, a, mesh.vertices);
  EquilibriumDifferentiator differentiator(model, solver.fixed_mask());
  std::string error;
  ASSERT_TRUE(differentiator.Prepare(x, a, &error)) << error;
  // Two motions of the fixed face: a shear and a rotation-like field.
  Eigen::MatrixXd motion = Eigen::MatrixXd::Zero(3 * mesh.num_vertices(), 2);
  for (int v : bc.vertices) {
    const Eigen::Vector3d p = mesh.vertices.col(v);
    motion.block<3, 1>(3 * v, 0) = Eigen::Vector3d(0.0, 1.0, 0.5);
    motion.block<3, 1>(3 * v, 1) = Eigen::Vector3d(0.0, -p.z(), p.y());
  }
  const Eigen::MatrixXd dx = differentiator.FixedVertexJacobianProduct(motion);
  for (int c = 0; c < 2; ++c) {
    auto equilibrium_along = [&](const Eigen::VectorXd& t) -> Eigen::VectorXd {
      Eigen::Matrix3Xd fixed(3, bc.vertices.size());
      for (size_t i = 0; i < bc.vertices.size(); ++i) {
        const int v = bc.vertices[i];
        fixed.col(i) = mesh.vertices.col(v) + t[0] * motion.block<3, 1>(3 * v, c);
      }
      solver.SetFixedPositions(fixed);
      const Eigen::Matrix3Xd xt = Equilibrium(&solver, a, x);
      return Eigen::Map<const Eigen::VectorXd>(xt.data(), xt.size());
    };
    const Eigen::VectorXd numeric = testing::CentralDifferenceDirectional(
        equilibrium_along, Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), 1e-4);
    EXPECT_LT(testing::RelativeError(dx.col(c), numeric), 1e-6) << "motion " << c;
  }
}

// The free-DOF rows of a 3 x num_vertices field (or a flattened one), in the pattern's
// order.
Eigen::VectorXd GatherFree(const StiffnessPattern& pattern, const double* field) {
  Eigen::VectorXd out(pattern.num_dofs());
  for (int f = 0; f < pattern.num_free_vertices(); ++f) {
    out.segment<3>(3 * f) =
        Eigen::Map<const Eigen::Vector3d>(field + 3 * pattern.vertex_of_free(f));
  }
  return out;
}

// Without re-solves, at states that are not equilibria (Prepare only needs K positive
// definite): a rotated, deformed and actuated bar, its left face fixed. The exact K is
// checked against differenced forces along random free motions, K_free,fixed (assembled
// by hand for FixedVertexJacobianProduct) against the forces' change under motions of
// the fixed vertices, the actuation products against ActuationForceProducts through K,
// and the adjoint gradient against the products (<dL/da, v> = <dL/dx, dx*/da v>).
TEST(EquilibriumDifferentiatorTest, ProductsSolveTheirSystemsAtRotatedDeformedStates) {
  const TetMesh mesh = testing::BarMesh(4, 2, 2, 0.3);
  const ShapeTargetModel model(mesh, 1.3);
  const BoundaryConditions bc = testing::LeftFaceFixed(mesh);
  std::vector<bool> fixed(mesh.num_vertices(), false);
  for (int v : bc.vertices) fixed[v] = true;
  std::mt19937 rng(77);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int n = mesh.num_vertices();
  for (const double deformation : {0.02, 0.06}) {
    Eigen::Matrix3Xd x = mesh.vertices;
    for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += deformation * normal(rng);
    x = testing::RandomRotation(&rng) * x;
    const ActuationMatrix a = testing::RandomActuation(mesh.num_tets(), 0.15, &rng);
    EquilibriumDifferentiator differentiator(model, fixed);
    std::string error;
    ASSERT_TRUE(differentiator.Prepare(x, a, &error)) << error;
    const StiffnessPattern& pattern = differentiator.factorization().pattern();
    auto free_gradient_at = [&](const Eigen::Matrix3Xd& y) {
      Eigen::Matrix3Xd gradient;
      model.EnergyAndGradient(y, a, &gradient, 1);
      return GatherFree(pattern, gradient.data());
    };
    // K w against differenced forces along a motion w of the free vertices.
    Eigen::Matrix3Xd w = Eigen::Matrix3Xd::Zero(3, n);
    for (int v = 0; v < n; ++v) {
      if (!fixed[v]) w.col(v) = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    }
    auto along = [&](const Eigen::Matrix3Xd& motion) {
      return [&, motion](const Eigen::VectorXd& t) -> Eigen::VectorXd {
        return free_gradient_at(x + t[0] * motion);
      };
    };
    const Eigen::VectorXd one = Eigen::VectorXd::Ones(1), zero = Eigen::VectorXd::Zero(1);
    EXPECT_LT(testing::RelativeError(
                  differentiator.factorization().MultiplyAssembled(GatherFree(pattern, w.data())),
                  testing::CentralDifferenceDirectional(along(w), zero, one, 1e-5)),
              1e-9)
        << "deformation " << deformation;
    // K dx_free = -K_free,fixed m: the forces' change when the fixed vertices move by m.
    Eigen::MatrixXd motion = Eigen::MatrixXd::Zero(3 * n, 2);
    for (int v : bc.vertices) {
      for (int c = 0; c < 2; ++c) {
        motion.block<3, 1>(3 * v, c) = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      }
    }
    const Eigen::MatrixXd dx = differentiator.FixedVertexJacobianProduct(motion);
    for (int c = 0; c < 2; ++c) {
      const Eigen::Matrix3Xd m = Eigen::Map<const Eigen::Matrix3Xd>(motion.col(c).data(), 3, n);
      EXPECT_LT(testing::RelativeError(
                    differentiator.factorization().MultiplyAssembled(
                        GatherFree(pattern, dx.col(c).data())),
                    -testing::CentralDifferenceDirectional(along(m), zero, one, 1e-5)),
                1e-9)
          << "deformation " << deformation << ", fixed-vertex motion " << c;
      for (int v : bc.vertices) {
        EXPECT_EQ(Eigen::Vector3d(dx.block(3 * v, c, 3, 1)),
                  Eigen::Vector3d(motion.block(3 * v, c, 3, 1)));
      }
    }
    // K dx*/da v = -B v, and the adjoint's gradient is the products' transpose.
    Eigen::MatrixXd directions(6 * mesh.num_tets(), 2);
    for (Eigen::Index i = 0; i < directions.size(); ++i) directions.data()[i] = normal(rng);
    const Eigen::MatrixXd jvp = differentiator.ActuationJacobianProduct(directions);
    const Eigen::MatrixXd force_change =
        ActuationForceProducts(model, pattern, x, a, directions, 1);
    Eigen::Matrix3Xd dl_dx(3, n);
    for (Eigen::Index i = 0; i < dl_dx.size(); ++i) dl_dx.data()[i] = normal(rng);
    const ActuationMatrix dl_da = differentiator.LossGradient(dl_dx);
    for (int c = 0; c < 2; ++c) {
      EXPECT_LT(testing::RelativeError(differentiator.factorization().MultiplyAssembled(
                                           GatherFree(pattern, jvp.col(c).data())),
                                       force_change.col(c)),
                1e-12);
      Eigen::Matrix3Xd free_dl = dl_dx;
      for (int v : bc.vertices) free_dl.col(v).setZero();
      const double through_products =
          Eigen::Map<const Eigen::VectorXd>(free_dl.data(), free_dl.size()).dot(jvp.col(c));
      const double adjoint =
          Eigen::Map<const Eigen::VectorXd>(dl_da.data(), dl_da.size()).dot(directions.col(c));
      EXPECT_NEAR(adjoint, through_products, 1e-10 * (1 + std::abs(through_products)));
    }
  }
}

// The deferred adjoint (options.reuse): with a factor of a nearby state in the shared
// factorization, Prepare only assembles K and the gradient comes from CG preconditioned
// by that factor, without a factorization, to the CG tolerance of the exact one. From the
// rest state's factor CG gives up within its iterations and K is factorized: the same
// gradient again.
TEST(EquilibriumDifferentiatorTest, DeferredAdjointReusesANearbyFactor) {
  const AdjointScene scene = MakeAdjointScene(5, 41, true);
  const ShapeTargetModel& model = *scene.model;
  EquilibriumDifferentiator exact(model, scene.solver->fixed_mask());
  std::string error;
  ASSERT_TRUE(exact.Prepare(scene.x, scene.a, &error)) << error;
  const ActuationMatrix reference = exact.LossGradient(scene.x - scene.y);

  EquilibriumDifferentiatorOptions options;
  options.reuse.max_iterations = 20;
  options.reuse.relative_tolerance = 1e-12;
  for (const bool nearby : {true, false}) {
    SCOPED_TRACE(nearby ? "a factor 1e-3 away" : "the factor of the rest state");
    StiffnessFactorization shared(model, scene.solver->fixed_mask(), 1);
    std::mt19937 rng(43);
    std::normal_distribution<double> normal(0.0, 1e-3);
    Eigen::Matrix3Xd x = scene.x;
    ActuationMatrix a = scene.a;
    if (nearby) {
      for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += normal(rng);
      for (Eigen::Index i = 0; i < a.size(); ++i) a.data()[i] += normal(rng);
    } else {
      x = scene.mesh.vertices;
      a = IdentityActuations(model.num_elements());
    }
    ASSERT_TRUE(shared.Factorize(x, a, StiffnessKind::kExact, &error)) << error;
    shared.ResetCounters();
    EquilibriumDifferentiator deferred(&shared, options);
    ASSERT_TRUE(deferred.Prepare(scene.x, scene.a, &error)) << error;
    ActuationMatrix gradient;
    ASSERT_TRUE(deferred.LossGradient(scene.x - scene.y, &gradient, &error)) << error;
    EXPECT_LT(testing::RelativeError(gradient, reference), 1e-9);
    if (nearby) {
      EXPECT_EQ(shared.counters().factorizations, 0);
      EXPECT_EQ(shared.counters().reused_solves, 1);
      EXPECT_GT(shared.counters().cg_iterations, 0);
    } else {
      EXPECT_EQ(shared.counters().factorizations, 1);
      EXPECT_EQ(shared.counters().failed_reuses, 1);
    }
  }
}

// A differentiator sharing a solver's factorization, prepared at one equilibrium, after
// the solver solved another actuation on that factorization: its K and factor are of
// another state, and the gradients and products would be silently wrong (31% and 28%
// off on this bar before 2026-12-07). Every use CHECKs that the factorization is as
// Prepare left it; Prepare again makes it right. The deferred adjoint's own
// factorization (of the K Prepare assembled) does not count as a change.
TEST(EquilibriumDifferentiatorTest, RefusesAFactorizationChangedSincePrepare) {
  ::testing::FLAGS_gtest_death_test_style = "threadsafe";  // the solver's threads
  const TetMesh mesh = testing::BarMesh(4, 2, 2, 0.4);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolver solver(model, testing::LeftFaceFixed(mesh), SolverOptions());
  const ActuationMatrix a1 = testing::SmoothActuation(mesh, 0.2);
  const ActuationMatrix a2 = testing::SmoothActuation(mesh, 0.35);
  solver.actuation() = a1;
  ASSERT_TRUE(solver.Solve().converged);
  const Eigen::Matrix3Xd x1 = solver.positions();
  const Eigen::Matrix3Xd dl_dx = Eigen::Matrix3Xd::Constant(3, x1.cols(), 0.1);
  EquilibriumDifferentiator own(model, solver.fixed_mask());
  std::string error;
  ASSERT_TRUE(own.Prepare(x1, a1, &error)) << error;
  const ActuationMatrix reference = own.LossGradient(dl_dx);
  const Eigen::MatrixXd direction =
      Eigen::MatrixXd::Constant(6 * static_cast<Eigen::Index>(model.num_elements()), 1, 0.01);
  const Eigen::MatrixXd product_reference = own.ActuationJacobianProduct(direction);

  EquilibriumDifferentiator shared(solver.stiffness_factorization());
  ASSERT_TRUE(shared.Prepare(x1, a1, &error)) << error;
  solver.actuation() = a2;
  ASSERT_GT(solver.Solve().factorizations, 0);
  EXPECT_DEATH(shared.LossGradient(dl_dx), "changed since Prepare");
  EXPECT_DEATH(shared.ActuationJacobianProduct(direction), "changed since Prepare");
  ActuationMatrix gradient;
  EXPECT_DEATH(shared.LossGradient(dl_dx, &gradient, &error), "changed since Prepare");
  ASSERT_TRUE(shared.Prepare(x1, a1, &error)) << error;
  // dL/dx of another mesh is named as such (it was a check inside the factorization).
  EXPECT_DEATH(shared.LossGradient(Eigen::Matrix3Xd::Zero(3, 5)),
               "dL/dx has 5 columns, the model [0-9]+ vertices");
  EXPECT_LT(testing::RelativeError(shared.LossGradient(dl_dx), reference), 1e-12);
  EXPECT_LT((shared.ActuationJacobianProduct(direction) - product_reference).norm(),
            1e-12 * product_reference.norm());

  EquilibriumDifferentiatorOptions deferred_options;
  deferred_options.reuse.max_iterations = 20;
  deferred_options.reuse.relative_tolerance = 1e-12;
  EquilibriumDifferentiator deferred(solver.stiffness_factorization(), deferred_options);
  ASSERT_TRUE(deferred.Prepare(x1, a1, &error)) << error;
  solver.stiffness_factorization()->RequestRefresh();  // its adjoint solve factorizes
  ASSERT_TRUE(deferred.LossGradient(dl_dx, &gradient, &error)) << error;
  EXPECT_LT(testing::RelativeError(gradient, reference), 1e-10);
  ASSERT_TRUE(deferred.LossGradient(dl_dx, &gradient, &error)) << error;  // no CHECK
  const int64_t generation = solver.stiffness_factorization()->generation();
  solver.actuation() = a1;
  solver.SetPositions(mesh.vertices);
  ASSERT_TRUE(solver.Solve().converged);
  ASSERT_NE(solver.stiffness_factorization()->generation(), generation);
  EXPECT_DEATH(deferred.LossGradient(dl_dx, &gradient, &error), "changed since Prepare");
}

TEST(NewtonRefinementTest, ConvergesQuadraticallyFromSolverResult) {
  const TetMesh mesh = testing::BarMesh(5, 2, 2, 0.4);
  const ShapeTargetModel model(mesh, 1.0);
  QuasistaticSolverOptions options;
  options.relative_force_tolerance = 1e-4;  // a loose start
  options.method = EquilibriumMethod::kLevenbergMarquardt;
  options.newton_relative_force = 0.0;      // Levenberg-Marquardt only
  QuasistaticSolver solver(model, testing::LeftFaceFixed(mesh), options);
  solver.actuation() = testing::SmoothActuation(mesh, 0.3);
  ASSERT_TRUE(solver.Solve().converged);
  StiffnessFactorization factorization(model, solver.fixed_mask(), 2);
  Eigen::Matrix3Xd x = solver.positions();
  NewtonSolverOptions refine;
  refine.force_tolerance = 1e-13 * model.force_scale();
  const NewtonSolveReport report =
      MinimizeEnergyNewton(refine, solver.actuation(), &factorization, &x);
  EXPECT_TRUE(report.converged) << report.message;
  EXPECT_EQ(report.projected_steps, 0);
  EXPECT_LE(report.factorizations, 3) << "quadratic convergence from 1e-4";
  EXPECT_LE(report.final_max_force, refine.force_tolerance);
  for (int v : solver.fixed_vertices()) EXPECT_EQ((x.col(v) - mesh.vertices.col(v)).norm(), 0.0);
}

TEST(EquilibriumDifferentiatorTest, ReportsStiffnessThatIsNotPositiveDefinite) {
  const TetMesh mesh = testing::BarMesh(4, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  const BoundaryConditions bc = testing::LeftFaceFixed(mesh);
  EquilibriumDifferentiator differentiator(model, FixedVertexMask(bc, mesh.num_vertices()));
  // Every element squeezed to 30%: twist modes have negative stiffness.
  Eigen::Matrix3Xd squeezed = 0.3 * mesh.vertices;
  for (int v : bc.vertices) squeezed.col(v) = mesh.vertices.col(v);
  std::string error;
  EXPECT_FALSE(differentiator.Prepare(squeezed, IdentityActuations(mesh.num_tets()), &error));
  EXPECT_NE(error.find("not positive definite"), std::string::npos) << error;
  EXPECT_NE(error.find("of vertex"), std::string::npos) << error;
  // And it works at a stable equilibrium afterwards.
  EXPECT_TRUE(differentiator.Prepare(mesh.vertices, IdentityActuations(mesh.num_tets()), &error))
      << error;
}

// The shifted adjoint (PrepareShifted): at a stable equilibrium a shift of 1e-10 gives
// the exact gradient to 1e-7, a shift of 1e-2 a visibly different one; and it factorizes
// a stiffness whose unshifted form is not positive definite, once the shift is large
// enough.
TEST(EquilibriumDifferentiatorTest, ShiftedAdjointApproachesTheExactGradient) {
  AdjointScene scene = MakeAdjointScene(3, 23, false);
  const TetMesh& mesh = scene.mesh;
  const ShapeTargetModel& model = *scene.model;
  const BoundaryConditions& bc = scene.bc;
  const QuasistaticSolver& solver = *scene.solver;
  const ActuationMatrix& a = scene.a;
  const Eigen::Matrix3Xd& x = scene.x;
  const Eigen::Matrix3Xd& y = scene.y;
  EquilibriumDifferentiator differentiator(model, solver.fixed_mask());
  std::string error;
  ASSERT_TRUE(differentiator.Prepare(x, a, &error)) << error;
  const ActuationMatrix exact = differentiator.LossGradient(x - y);
  ASSERT_TRUE(differentiator.PrepareShifted(x, a, 1e-10, &error)) << error;
  const ActuationMatrix tiny = differentiator.LossGradient(x - y);
  ASSERT_TRUE(differentiator.PrepareShifted(x, a, 1e-2, &error)) << error;
  const ActuationMatrix large = differentiator.LossGradient(x - y);
  EXPECT_LT((tiny - exact).norm(), 1e-7 * exact.norm());
  EXPECT_GT((large - exact).norm(), 1e-4 * exact.norm());
  EXPECT_LT((large - exact).norm(), exact.norm());
  // The shift is relative to K's own scale: with mu 1000 times larger, x is the same
  // equilibrium, K and dg/da are 1000 times larger and the adjoint 1000 times smaller, so
  // the shifted gradient is the same (a shift of 1e-2 absolute would be 1000 times
  // smaller relative to this K).
  const ShapeTargetModel stiffer(mesh, Eigen::VectorXd(1000.0 * model.mu()));
  EquilibriumDifferentiator stiffer_differentiator(stiffer, solver.fixed_mask());
  ASSERT_TRUE(stiffer_differentiator.PrepareShifted(x, a, 1e-2, &error)) << error;
  EXPECT_LT((stiffer_differentiator.LossGradient(x - y) - large).norm(), 1e-10 * large.norm());

  // Squeezed to 30%: not positive definite unshifted (see the test above), definite
  // with a large enough shift.
  Eigen::Matrix3Xd squeezed = 0.3 * mesh.vertices;
  for (int v : bc.vertices) squeezed.col(v) = mesh.vertices.col(v);
  const ActuationMatrix identity = IdentityActuations(mesh.num_tets());
  EXPECT_FALSE(differentiator.Prepare(squeezed, identity, &error));
  double shift = 1e-10;
  while (shift <= 1e6 && !differentiator.PrepareShifted(squeezed, identity, shift, &error)) {
    shift *= 100.0;
  }
  EXPECT_LE(shift, 1e6) << error;
  std::printf("squeezed bar: definite from a relative shift of %.0e\n", shift);
}

}  // namespace
}  // namespace aqs
