#include "equilibrium/negative_curvature.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "physics/boundary_conditions.h"
#include "physics/stiffness_assembly.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

using testing::BarMesh;

// A bar held at both ends whose fibres want to be `stretch` times longer: compressed,
// and beyond the buckling load its straight state is a saddle of the energy.
struct HeldBar {
  explicit HeldBar(double stretch) : mesh(BarMesh(12, 2, 2, 0.5)), model(mesh, 1.0) {
    const double length = mesh.vertices.row(0).maxCoeff();
    for (int v = 0; v < mesh.num_vertices(); ++v) {
      if (mesh.vertices(0, v) < 1e-9 || mesh.vertices(0, v) > length - 1e-9) bc.vertices.push_back(v);
    }
    a = IdentityActuations(mesh.num_tets());
    a.row(0).setConstant(stretch);
  }
  std::vector<bool> Fixed() const { return FixedVertexMask(bc, mesh.num_vertices()); }
  TetMesh mesh;
  ShapeTargetModel model;
  BoundaryConditions bc;
  ActuationMatrix a;
};

// The exact K at x (values, and dense with its mean |diagonal|), leaving `factorization`
// holding the factor of the projected K at x.
std::vector<double> ExactValuesWithProjectedFactor(const HeldBar& bar, const Eigen::Matrix3Xd& x,
                                                   StiffnessFactorization* factorization,
                                                   Eigen::MatrixXd* dense) {
  factorization->Assemble(x, bar.a, StiffnessKind::kExact);
  const std::vector<double> exact = factorization->values();
  *dense = DenseFromUpperCsc(factorization->pattern(), exact);
  std::string error;
  EXPECT_TRUE(factorization->Factorize(x, bar.a, StiffnessKind::kProjected, &error)) << error;
  return exact;
}

// The bar at its rest positions (straight): the exact K there, dense, and the factor of
// the projected K held by `factorization`.
struct StraightBar {
  explicit StraightBar(double stretch)
      : bar(stretch), factorization(bar.model, bar.Fixed(), 1),
        exact(ExactValuesWithProjectedFactor(bar, bar.mesh.vertices, &factorization, &dense)) {}
  HeldBar bar;
  StiffnessFactorization factorization;
  Eigen::MatrixXd dense;
  std::vector<double> exact;
};

// The smallest eigenvalue of the dense stiffness K over its mean |diagonal|.
double RelativeSmallestEigenvalue(const Eigen::MatrixXd& dense) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense).eigenvalues()[0] /
         dense.diagonal().cwiseAbs().mean();
}

// A search's result against K (dense): the reported curvature is its direction's Rayleigh
// quotient over K's mean |diagonal|, between K's smallest (relative) eigenvalue and
// `fraction` of it.
void ExpectNearTheSmallestEigenvalue(const Eigen::MatrixXd& dense,
                                     const Eigen::VectorXd& direction, double curvature,
                                     double fraction, const char* what) {
  const double smallest = RelativeSmallestEigenvalue(dense);
  std::printf("%s: curvature %.6g, smallest eigenvalue %.6g\n", what, curvature, smallest);
  EXPECT_NEAR(direction.norm(), 1.0, 1e-12);
  EXPECT_NEAR(curvature, direction.dot(dense * direction) / dense.diagonal().cwiseAbs().mean(),
              1e-12);
  EXPECT_LT(curvature, fraction * smallest) << what;
  EXPECT_GE(curvature, smallest - 1e-12) << what;
}

TEST(NegativeCurvatureTest, FindsTheMostNegativeCurvatureOfASaddle) {
  StraightBar straight(1.4);
  ASSERT_LT(RelativeSmallestEigenvalue(straight.dense), 0.0)
      << "the straight compressed bar should be a saddle";
  Eigen::VectorXd direction;
  double curvature = 0.0;
  ASSERT_TRUE(
      FindNegativeCurvature(straight.exact, 30, &straight.factorization, &direction, &curvature));
  // The smallest eigenvalue (the buckling mode) within 1%: the search minimizes K's own
  // Rayleigh quotient. (Power iteration on I - P^-1 K, the search before 2026-12-06,
  // reached 65% of it: the most negative mode of K relative to the projected K.)
  ExpectNearTheSmallestEigenvalue(straight.dense, direction, curvature, 0.99, "saddle");
}

// A projected stiffness P that is not above the exact K everywhere, as in contact solves,
// where P holds a pair's Gauss-Newton part and K also its curvature term: here K gets a
// stiff spring (100 times the mean |diagonal|) on the DOFs of one free vertex that P
// lacks. Then I - P^-1 K has eigenvalues below -1 (K v = lambda P v with lambda > 2),
// which dominate plain power iteration; the search must still find the buckling mode.
TEST(NegativeCurvatureTest, FindsItWhereTheProjectedStiffnessIsNotAboveTheExact) {
  StraightBar straight(1.4);
  StiffnessFactorization& factorization = straight.factorization;
  const StiffnessPattern& pattern = factorization.pattern();
  std::vector<double> exact = straight.exact;
  const double scale = straight.dense.diagonal().cwiseAbs().mean();
  // The free vertex nearest the fixed end x = 0, where the buckling mode moves least.
  int spring = pattern.vertex_of_free(0);
  for (int f = 1; f < pattern.num_free_vertices(); ++f) {
    const int v = pattern.vertex_of_free(f);
    if (straight.bar.mesh.vertices(0, v) < straight.bar.mesh.vertices(0, spring)) spring = v;
  }
  for (int d = 0; d < 3; ++d) {
    exact[pattern.VertexBlockOffset(spring, spring, d) + d] += 100.0 * scale;
  }
  const Eigen::MatrixXd dense = DenseFromUpperCsc(pattern, exact);
  ASSERT_LT(RelativeSmallestEigenvalue(dense), 0.0) << "still a saddle";
  Eigen::VectorXd direction;
  double curvature = 0.0;
  ASSERT_TRUE(FindNegativeCurvature(exact, 30, &factorization, &direction, &curvature));
  // The preconditioner misses the spring, so the search converges more slowly than
  // without it: within 10% in its 30 iterations.
  ExpectNearTheSmallestEigenvalue(dense, direction, curvature, 0.9, "with the spring");
}

TEST(NegativeCurvatureTest, FindsNoneWhereTheStiffnessIsDefinite) {
  StraightBar straight(1.0);  // at rest: K positive definite
  const HeldBar& bar = straight.bar;
  const Eigen::MatrixXd& dense = straight.dense;
  const std::vector<double>& exact = straight.exact;
  StiffnessFactorization& factorization = straight.factorization;
  ASSERT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense).eigenvalues()[0], 0.0);
  Eigen::VectorXd direction;
  double curvature = 0.0;
  EXPECT_FALSE(FindNegativeCurvature(exact, 30, &factorization, &direction, &curvature));
  // Without a factor there is nothing to iterate with.
  StiffnessFactorization empty(bar.model, bar.Fixed(), 1);
  EXPECT_FALSE(FindNegativeCurvature(exact, 30, &empty, &direction, &curvature));
}

// A free body at rest: K is positive semi-definite with six zero modes (rigid motions),
// which the search converges to; their quotient is round-off (about 1e-17), no negative
// curvature.
TEST(NegativeCurvatureTest, FindsNoneWhereTheStiffnessIsSingularButNotIndefinite) {
  const TetMesh mesh = BarMesh(4, 2, 2, 0.5);
  const ShapeTargetModel model(mesh, 1.0);
  StiffnessFactorization factorization(model, std::vector<bool>(mesh.num_vertices(), false), 1);
  const ActuationMatrix a = IdentityActuations(mesh.num_tets());
  factorization.Assemble(mesh.vertices, a, StiffnessKind::kExact);
  const std::vector<double> exact = factorization.values();
  factorization.Assemble(mesh.vertices, a, StiffnessKind::kProjected);
  std::string error;
  ASSERT_TRUE(factorization.FactorizeAssembled(1e-6, &error)) << error;
  Eigen::VectorXd direction;
  double curvature = 0.0;
  EXPECT_FALSE(FindNegativeCurvature(exact, 30, &factorization, &direction, &curvature))
      << curvature;
}

TEST(NegativeCurvatureTest, StepLowersTheEnergyOfASaddleAndKeepsFixedVertices) {
  StraightBar straight(1.4);
  const HeldBar& bar = straight.bar;
  StiffnessFactorization& factorization = straight.factorization;
  const std::vector<double>& exact = straight.exact;
  Eigen::VectorXd direction;
  double curvature = 0.0;
  ASSERT_TRUE(FindNegativeCurvature(exact, 30, &factorization, &direction, &curvature));
  for (const double sign : {1.0, -1.0}) {  // either sign of d: the step picks the downhill one
    Eigen::Matrix3Xd x = bar.mesh.vertices;
    Eigen::Matrix3Xd gradient;
    double energy = factorization.EnergyAndGradient(x, bar.a, &gradient);
    const double saddle_energy = energy;
    const NegativeCurvatureStep step = StepAlongNegativeCurvature(
        factorization, bar.a, sign * direction, 1e-3, 30, &x, &energy, &gradient);
    ASSERT_TRUE(step.accepted);
    EXPECT_LT(energy, saddle_energy * (1.0 - 1e-3));
    // It expanded from the first trial length (1e-3) by doubling.
    EXPECT_GT(step.length, 1e-2);
    EXPECT_GT(step.energy_evaluations, 3);
    Eigen::Matrix3Xd check;
    EXPECT_DOUBLE_EQ(factorization.EnergyAndGradient(x, bar.a, &check), energy);
    EXPECT_TRUE(check.isApprox(gradient));
    for (int v : bar.bc.vertices) EXPECT_EQ((x.col(v) - bar.mesh.vertices.col(v)).norm(), 0.0);
  }
}

// Off the saddle (moved along its negative-curvature direction d, where the gradient g
// has g . d != 0) the step orients d itself: d and -d give the same state, bit for bit,
// and it moves downhill (its displacement . g < 0).
TEST(NegativeCurvatureTest, StepGoesDownhillWhereTheGradientIsNotZero) {
  StraightBar straight(1.4);
  const HeldBar& bar = straight.bar;
  StiffnessFactorization& factorization = straight.factorization;
  Eigen::VectorXd direction;
  double curvature = 0.0;
  ASSERT_TRUE(FindNegativeCurvature(straight.exact, 30, &factorization, &direction, &curvature));
  Eigen::Matrix3Xd d = factorization.ScatterFree(direction.data());
  const Eigen::Matrix3Xd start = bar.mesh.vertices + 1e-3 * d / d.colwise().norm().maxCoeff();
  Eigen::Matrix3Xd start_gradient;
  const double start_energy = factorization.EnergyAndGradient(start, bar.a, &start_gradient);
  ASSERT_GT(std::abs(start_gradient.cwiseProduct(d).sum()), 0.0);
  std::vector<Eigen::Matrix3Xd> ends;
  for (const double sign : {1.0, -1.0}) {
    Eigen::Matrix3Xd x = start;
    Eigen::Matrix3Xd gradient = start_gradient;
    double energy = start_energy;
    const NegativeCurvatureStep step = StepAlongNegativeCurvature(
        factorization, bar.a, sign * direction, 1e-3, 30, &x, &energy, &gradient);
    ASSERT_TRUE(step.accepted) << "sign " << sign;
    EXPECT_LT(energy, start_energy);
    EXPECT_LT((x - start).cwiseProduct(start_gradient).sum(), 0.0) << "sign " << sign;
    ends.push_back(x);
  }
  EXPECT_EQ(ends[0], ends[1]);
}

}  // namespace
}  // namespace aqs
