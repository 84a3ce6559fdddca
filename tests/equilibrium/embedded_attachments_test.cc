#include "equilibrium/embedded_attachments.h"

#include <memory>
#include <random>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <gtest/gtest.h>

#include "equilibrium/quasistatic_solver.h"
#include "physics/stiffness_assembly.h"
#include "testing/finite_difference.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

// Random points embedded in random elements of a bar (weights in the element,
// some slightly outside as extrapolated embeddings are; random offsets, as points
// outside the mesh have).
struct Fixture {
  TetMesh mesh = testing::BarMesh(4, 2, 2, 0.5);
  Embedding embedding;
  Eigen::VectorXd stiffness;

  explicit Fixture(int n, unsigned seed = 1) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> pick(0, mesh.num_tets() - 1);
    std::uniform_real_distribution<double> uniform(-0.1, 1.0);
    std::uniform_real_distribution<double> k(0.5, 3.0);
    std::uniform_real_distribution<double> offset(-0.05, 0.05);
    embedding.weights.resize(4, n);
    embedding.offsets.resize(3, n);
    stiffness.resize(n);
    for (int i = 0; i < n; ++i) {
      embedding.element.push_back(pick(rng));
      Eigen::Vector4d w;
      for (int j = 0; j < 4; ++j) w[j] = uniform(rng);
      embedding.weights.col(i) = w / w.sum();
      for (int j = 0; j < 3; ++j) embedding.offsets(j, i) = offset(rng);
      embedding.outside_distance.push_back(embedding.offsets.col(i).norm());
      stiffness[i] = k(rng);
    }
  }
};

TEST(EmbeddedAttachmentsTest, GradientAndStiffnessMatchFiniteDifferences) {
  Fixture f(30);
  EmbeddedAttachments term(f.embedding, f.mesh.tets, f.stiffness, f.mesh.vertices);
  std::mt19937 rng(2);
  std::normal_distribution<double> normal(0.0, 0.2);
  Eigen::Matrix3Xd moved = term.targets();
  for (int i = 0; i < moved.size(); ++i) moved.data()[i] += normal(rng);
  term.targets() = moved;
  Eigen::Matrix3Xd x = f.mesh.vertices;
  for (int i = 0; i < x.size(); ++i) x.data()[i] += normal(rng);
  const int n = static_cast<int>(x.size());
  auto energy = [&](const Eigen::VectorXd& flat) {
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, f.mesh.num_vertices());
    return term.AddEnergyAndGradient(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, n / 3), &g);
  };
  Eigen::Matrix3Xd gradient = Eigen::Matrix3Xd::Zero(3, f.mesh.num_vertices());
  term.AddEnergyAndGradient(x, &gradient);
  const Eigen::VectorXd flat = Eigen::Map<const Eigen::VectorXd>(x.data(), n);
  EXPECT_LT(testing::RelativeError(Eigen::Map<const Eigen::VectorXd>(gradient.data(), n),
                                   testing::CentralDifferenceGradient(energy, flat, 1e-6)),
            1e-8);
  // Hessian on all DOFs (no fixed vertices) against differences of the gradient.
  const StiffnessPattern pattern(f.mesh.tets, std::vector<bool>(f.mesh.num_vertices(), false));
  std::vector<double> values(pattern.num_nonzeros(), 0.0);
  term.AddStiffness(x, pattern, StiffnessKind::kExact, &values);
  auto grad = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, f.mesh.num_vertices());
    term.AddEnergyAndGradient(Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, n / 3), &g);
    return Eigen::Map<const Eigen::VectorXd>(g.data(), n);
  };
  EXPECT_LT(testing::RelativeError(DenseFromUpperCsc(pattern, values),
                                   testing::CentralDifferenceJacobian(grad, flat, 1e-6)),
            1e-8);
}

TEST(EmbeddedAttachmentsTest, CostFunctionPassesGradientCheckerAndMatchesEnergy) {
  const Eigen::Vector4d w(0.1, 0.5, 0.3, 0.1);
  const Eigen::Vector3d offset(0.02, -0.01, 0.03);
  const Eigen::Vector3d target(0.3, -0.2, 1.0);
  PointStencil stencil;
  for (int j = 0; j < 4; ++j) {
    stencil.vertex[j] = j;
    stencil.weight[j] = w[j];
  }
  stencil.offset = offset;
  std::unique_ptr<ceres::CostFunction> cost(NewAttachmentCostFunction(stencil, 2.5, target.data()));
  Eigen::Matrix<double, 3, 4> x = Eigen::Matrix<double, 3, 4>::Random();
  const double* parameters[4] = {x.col(0).data(), x.col(1).data(), x.col(2).data(),
                                 x.col(3).data()};
  const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
  ceres::NumericDiffOptions numeric_options;
  ceres::GradientChecker checker(cost.get(), no_manifolds, numeric_options);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(parameters, 1e-9, &results)) << results.error_log;
  double residuals[3];
  ASSERT_TRUE(cost->Evaluate(parameters, residuals, nullptr));
  const Eigen::Vector3d p = x * w + offset;
  EXPECT_NEAR(0.5 * Eigen::Map<Eigen::Vector3d>(residuals).squaredNorm(),
              0.5 * 2.5 * (p - target).squaredNorm(), 1e-14);
}

TEST(EmbeddedAttachmentsTest, CeresCostIsTheTermEnergy) {
  Fixture f(20, 3);
  EmbeddedAttachments term(f.embedding, f.mesh.tets, f.stiffness, f.mesh.vertices);
  term.targets() = term.targets() + Eigen::Matrix3Xd::Constant(3, 20, 0.1);
  Eigen::Matrix3Xd x = f.mesh.vertices + 0.05 * Eigen::Matrix3Xd::Random(3, f.mesh.num_vertices());
  ceres::Problem problem;
  std::vector<double*> blocks(f.mesh.num_vertices());
  for (int v = 0; v < f.mesh.num_vertices(); ++v) blocks[v] = x.col(v).data();
  term.AddResidualBlocks(&problem, blocks);
  double cost = 0;
  ASSERT_TRUE(problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr));
  Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, f.mesh.num_vertices());
  EXPECT_NEAR(cost, term.AddEnergyAndGradient(x, &g), 1e-12);
}

TEST(EmbeddedAttachmentsTest, SolverPullsEmbeddedPointsWithLevenbergMarquardtAndNewton) {
  const TetMesh mesh = testing::BarMesh(6, 2, 2, 0.4);
  const ShapeTargetModel model(mesh, 1.0);
  // Attach the free end's vertices (one-hot embeddings) and lift them by 0.3.
  Embedding embedding;
  std::vector<Eigen::Vector4d> weights;
  const double max_x = mesh.vertices.row(0).maxCoeff();
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int k = 0; k < 4; ++k) {
      if (mesh.vertices(0, mesh.tets(k, e)) > max_x - 1e-9) {
        embedding.element.push_back(e);
        embedding.outside_distance.push_back(0.0);
        weights.push_back(Eigen::Vector4d::Unit(k));
      }
    }
  }
  embedding.weights.resize(4, weights.size());
  for (size_t i = 0; i < weights.size(); ++i) embedding.weights.col(i) = weights[i];
  embedding.offsets.setZero(3, weights.size());
  const Eigen::VectorXd k = Eigen::VectorXd::Constant(embedding.num_points(), 50.0);
  Eigen::Matrix3Xd results[2];
  for (int run = 0; run < 2; ++run) {
    EmbeddedAttachments term(embedding, mesh.tets, k, mesh.vertices);
    term.targets() = term.targets().colwise() + Eigen::Vector3d(0, 0.3, 0);
    QuasistaticSolverOptions options;
    options.relative_force_tolerance = 1e-8;
    if (run == 0) {  // Levenberg-Marquardt alone
      options.method = EquilibriumMethod::kLevenbergMarquardt;
      options.newton_relative_force = 0.0;
    }
    QuasistaticSolver solver(model, testing::LeftFaceFixed(mesh), options);
    solver.AddEnergyTerm(&term);
    const QuasistaticSolveReport report = solver.Solve();
    ASSERT_TRUE(report.converged) << report.Summary();
    if (run == 1) {
      EXPECT_GT(report.newton_steps, 0) << report.Summary();
    }
    const Eigen::Matrix3Xd points = term.Points(solver.positions());
    // Stiff springs: the end follows its targets closely but not exactly (the bar resists).
    const double gap = (points - term.targets()).colwise().norm().maxCoeff();
    EXPECT_LT(gap, 0.05);
    EXPECT_GT(gap, 1e-5);
    results[run] = solver.positions();
  }
  EXPECT_LT((results[0] - results[1]).cwiseAbs().maxCoeff(), 1e-6);
}

}  // namespace
}  // namespace aqs
