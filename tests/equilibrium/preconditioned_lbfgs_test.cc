#include "equilibrium/preconditioned_lbfgs.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "equilibrium/energy_term.h"
#include "physics/boundary_conditions.h"
#include "physics/stiffness_assembly.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

using testing::BarMesh;
using testing::CurlActuation;
using testing::LeftFaceFixed;

// The 16 x 2 x 2 bar fixed at its left face, its fibres contracted above the middle and
// stretched below by 0.4: it curls far from its rest shape, the start of every run.
class CurlFromRestTest : public ::testing::Test {
 protected:
  CurlFromRestTest()
      : mesh_(BarMesh(16, 2, 2, 0.5)),
        model_(mesh_, 1.0),
        actuation_(CurlActuation(mesh_, 0.4)),
        factorization_(model_, FixedVertexMask(LeftFaceFixed(mesh_), mesh_.num_vertices()), 2) {
    options_.force_tolerance = 1e-2 * model_.force_scale();  // Newton's threshold
    options_.max_iterations = 300;
  }
  // Factorizes the rotation-fixed stiffness + relative_shift x its mean diagonal x I.
  void FactorizePreconditioner(double relative_shift) {
    std::string error;
    factorization_.Assemble(mesh_.vertices, actuation_, StiffnessKind::kRotationFixed);
    ASSERT_TRUE(factorization_.FactorizeAssembled(relative_shift, &error)) << error;
  }
  PreconditionedLbfgsReport Run(Eigen::Matrix3Xd* x) {
    *x = mesh_.vertices;
    return MinimizeEnergyLbfgs(options_, actuation_, &factorization_, x);
  }
  TetMesh mesh_;
  ShapeTargetModel model_;
  ActuationMatrix actuation_;
  StiffnessFactorization factorization_;
  PreconditionedLbfgsOptions options_;
};

// With its own preconditioner L-BFGS converges in 71 steps, though not monotonically in
// the largest force: it rises while the bar swings (from 0.036 back to 0.066 at step 11)
// and took 21 steps at worst to halve. A stall test at 30 steps never fires; at 20 it
// would (at step 40), which is why the solver applies it only to a reused factor
// (QuasistaticSolverOptions::lbfgs_reused_factor_stall_iterations).
TEST_F(CurlFromRestTest, HealthyRunDoesNotStall) {
  FactorizePreconditioner(0.0);
  options_.stall_iterations = 30;
  Eigen::Matrix3Xd x;
  const PreconditionedLbfgsReport report = Run(&x);
  EXPECT_TRUE(report.converged) << report.message;
  EXPECT_FALSE(report.stalled) << report.message;
  EXPECT_LT(report.iterations, 150) << report.message;
}

// A preconditioner far from the Hessian (shifted by 30 mean diagonals: steps along the
// soft modes a small fraction of the right length) makes L-BFGS crawl: without the stall
// test it runs to max_iterations without converging; with it, it stops after
// stall_iterations steps without a halving of the force, at a lower energy, and says why.
TEST_F(CurlFromRestTest, StopsWhereTheForceStopsHalving) {
  FactorizePreconditioner(30.0);
  Eigen::Matrix3Xd crawled, stopped;
  const PreconditionedLbfgsReport crawl = Run(&crawled);
  EXPECT_FALSE(crawl.converged) << crawl.message;
  EXPECT_FALSE(crawl.stalled) << crawl.message;
  EXPECT_EQ(crawl.iterations, options_.max_iterations) << crawl.message;

  options_.stall_iterations = 20;
  const PreconditionedLbfgsReport stall = Run(&stopped);
  EXPECT_TRUE(stall.stalled) << stall.message;
  EXPECT_FALSE(stall.converged) << stall.message;
  EXPECT_NE(stall.message.find("stalled"), std::string::npos) << stall.message;
  EXPECT_GE(stall.iterations, options_.stall_iterations);
  EXPECT_LT(stall.iterations, crawl.iterations);
  EXPECT_LT(stall.final_energy, stall.initial_energy);
  // The same steps as the crawl up to the stop (the test only stops, never steers).
  EXPECT_LE(crawl.final_energy, stall.final_energy);
}

// A hill under one vertex, E = c exp(-|x_v - p|^2 / (2 s^2)): concave within s of its
// top p, so that steps down it have correction pairs of negative curvature. As its
// preconditioner stiffness it adds k I (positive definite; its Hessian is not).
class HillTerm : public EnergyTerm {
 public:
  HillTerm(int vertex, const Eigen::Vector3d& top, double c, double s, double k)
      : vertex_(vertex), top_(top), c_(c), s_(s), k_(k) {}
  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override {
    const Eigen::Vector3d d = x.col(vertex_) - top_;
    const double e = c_ * std::exp(-d.squaredNorm() / (2.0 * s_ * s_));
    gradient->col(vertex_) -= e / (s_ * s_) * d;
    return e;
  }
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& /*x*/,
                    const StiffnessPattern& pattern, StiffnessKind /*kind*/,
                    std::vector<double>* values) const override {
    AddVertexHessian({vertex_}, k_ * Eigen::MatrixXd::Identity(3, 3), pattern, values);
  }
  void AddResidualBlocks(ceres::Problem* /*problem*/,
                         const std::vector<double*>& /*vertex_blocks*/) const override {
    ADD_FAILURE() << "L-BFGS builds no Ceres problem";
  }

 private:
  int vertex_;
  Eigen::Vector3d top_;
  double c_, s_, k_;
};

// Steps down the hill's concave top give pairs with s . y < 0: they are skipped (were they
// kept, the memory's inverse Hessian would be indefinite and its directions could ascend), and
// the descent off the hill converges without forgetting its memory.
TEST(PreconditionedLbfgsTest, PairsOfNegativeCurvatureAreSkipped) {
  const TetMesh mesh = BarMesh(8, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 10.0);
  int tip = 0;
  for (int v = 1; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) > mesh.vertices(0, tip)) tip = v;
  }
  const double s = 0.1;
  const Eigen::Vector3d top = mesh.vertices.col(tip) - Eigen::Vector3d(0.0, 0.2 * s, 0.0);
  const HillTerm hill(tip, top, 1.0, s, 10.0);
  StiffnessFactorization factorization(model, FixedVertexMask(LeftFaceFixed(mesh),
                                                              mesh.num_vertices()), 1);
  factorization.set_energy_terms({&hill});
  const ActuationMatrix a = IdentityActuations(mesh.num_tets());
  std::string error;
  factorization.Assemble(mesh.vertices, a, StiffnessKind::kRotationFixed);
  ASSERT_TRUE(factorization.FactorizeAssembled(0.0, &error)) << error;
  PreconditionedLbfgsOptions options;
  options.force_tolerance = 1e-6 * model.force_scale();
  options.max_iterations = 300;  // 66 needed (2026-12-07)
  Eigen::Matrix3Xd x = mesh.vertices;
  const PreconditionedLbfgsReport report = MinimizeEnergyLbfgs(options, a, &factorization, &x);
  std::printf("down the hill: %d iterations, %d pairs skipped, %d memory resets; %s\n",
              report.iterations, report.skipped_pairs, report.memory_resets,
              report.message.c_str());
  EXPECT_TRUE(report.converged) << report.message;
  EXPECT_GT(report.skipped_pairs, 0);
  EXPECT_EQ(report.memory_resets, 0);
  EXPECT_GT((x.col(tip) - top).norm(), s) << "off the hill's concave top";
}

TEST(PreconditionedLbfgsOptionsTest, StallFieldsAreValidated) {
  PreconditionedLbfgsOptions options;
  std::string error;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.stall_iterations = -1;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("stall_iterations"), std::string::npos) << error;
  options.stall_iterations = 10;
  for (double bad : {0.0, 1.0, -0.5}) {
    options.stall_reduction = bad;
    EXPECT_FALSE(options.Validate(&error)) << bad;
    EXPECT_NE(error.find("stall_reduction"), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace aqs
