#include "diff/actuation_force_products.h"

#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "mesh/tet_mesh.h"
#include "physics/boundary_conditions.h"
#include "physics/polar_cache.h"
#include "physics/shape_target_model.h"
#include "sparse/stiffness_pattern.h"
#include "testing/element_states.h"
#include "testing/finite_difference.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

// ActuationForceProducts returns -B v = -(d/dt) dE/dx (x, a + t v) at t = 0 on the free
// DOFs. The reference: central differences of the model's gradient along each direction,
// gathered onto the free DOFs in the pattern's order.
Eigen::MatrixXd ForceChangeByDifferences(const ShapeTargetModel& model,
                                         const StiffnessPattern& pattern,
                                         const Eigen::Matrix3Xd& x, const ActuationMatrix& a,
                                         const Eigen::MatrixXd& directions, double h) {
  const Eigen::Index n = a.size();
  auto free_gradient = [&](const Eigen::VectorXd& flat) {
    Eigen::Matrix3Xd gradient;
    model.EnergyAndGradient(x, Eigen::Map<const ActuationMatrix>(flat.data(), 6, a.cols()),
                            &gradient, 1);
    Eigen::VectorXd out = Eigen::VectorXd::Zero(pattern.num_dofs());
    for (int v = 0; v < pattern.num_vertices(); ++v) {
      const int f = pattern.free_index(v);
      if (f >= 0) out.segment<3>(3 * f) = gradient.col(v);
    }
    return out;
  };
  const Eigen::VectorXd flat_a = Eigen::Map<const Eigen::VectorXd>(a.data(), n);
  Eigen::MatrixXd out(pattern.num_dofs(), directions.cols());
  for (Eigen::Index c = 0; c < directions.cols(); ++c) {
    out.col(c) =
        -testing::CentralDifferenceDirectional(free_gradient, flat_a, directions.col(c), h);
  }
  return out;
}

Eigen::MatrixXd RandomDirections(int num_elements, int k, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd d(6 * num_elements, k);
  for (Eigen::Index i = 0; i < d.size(); ++i) d.data()[i] = normal(*rng);
  return d;
}

bool StartsWith(const std::string& name, const char* prefix) {
  return name.rfind(prefix, 0) == 0;
}

// One element, no vertex fixed, at every state the derivative tests share: near rest,
// random, rotated, compressed (indefinite), near-degenerate polar decompositions,
// inverted, anisotropic and sheared actuations. x = R F X (R a random rotation) and
// a = S of the state; three random directions per state.
TEST(ActuationForceProductsTest, MatchesDifferencedForcesAtEveryElementState) {
  const TetMesh mesh = testing::OneTetMesh();
  const ShapeTargetModel model(mesh, 1.7);
  const StiffnessPattern pattern(mesh.tets, std::vector<bool>(4, false));
  std::mt19937 rng(41);
  int checked = 0;
  for (const auto& state : testing::DerivativeTestStates(6, 42)) {
    const Eigen::Matrix3Xd x = testing::RandomRotation(&rng) * state.f * mesh.vertices;
    ActuationMatrix a(6, 1);
    a.col(0) = ActuationFromSymmetric(state.s);
    const Eigen::MatrixXd directions = RandomDirections(1, 3, &rng);
    const Eigen::MatrixXd products =
        ActuationForceProducts(model, pattern, x, a, directions, /*num_threads=*/1);
    ASSERT_EQ(products.rows(), 12);
    ASSERT_EQ(products.cols(), 3);
    // Next to a near-degenerate polar decomposition the rotation turns fast with S:
    // differences must stay well inside the singular-value gap.
    const bool near_degenerate = StartsWith(state.name, "near_degenerate");
    const double h = near_degenerate ? 1e-8 : 1e-5;
    const Eigen::MatrixXd expected = ForceChangeByDifferences(model, pattern, x, a, directions, h);
    EXPECT_LT(testing::RelativeError(products, expected), near_degenerate ? 1e-6 : 1e-8)
        << state.name;
    // Nodal forces of one element sum to zero for every direction (translation
    // invariance), so do their changes.
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d sum = products.col(c).reshaped(3, 4).rowwise().sum();
      EXPECT_LT(sum.norm(), 1e-10 * (1 + products.col(c).norm())) << state.name;
    }
    ++checked;
  }
  EXPECT_GE(checked, 10);
}

// A small mesh with shared vertices and two fixed ones, deformed, rotated and
// actuated at random, on two threads and from a PolarCache: each free DOF collects the
// changes of every element at its vertex; fixed vertices have no rows. The products
// are linear in the directions, and bit-identical for 1 and 2 threads.
TEST(ActuationForceProductsTest, AssemblesOntoFreeDofsAndIsLinearInDirections) {
  const TetMesh mesh = testing::ThreeTetMesh();
  Eigen::VectorXd mu(3);
  mu << 1.0, 2.5, 0.7;
  const ShapeTargetModel model(mesh, mu);
  std::vector<bool> fixed(6, false);
  fixed[0] = fixed[5] = true;
  const StiffnessPattern pattern(mesh.tets, fixed);
  ASSERT_EQ(pattern.num_dofs(), 12);
  std::mt19937 rng(43);
  std::normal_distribution<double> normal(0.0, 0.15);
  std::uniform_real_distribution<double> uniform(-0.3, 0.3);
  for (int trial = 0; trial < 4; ++trial) {
    Eigen::Matrix3Xd x = mesh.vertices;
    for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += normal(rng);
    x = testing::RandomRotation(&rng) * x;
    ActuationMatrix a = IdentityActuations(3);
    for (Eigen::Index i = 0; i < a.size(); ++i) a.data()[i] += uniform(rng);
    const Eigen::MatrixXd directions = RandomDirections(3, 2, &rng);
    const Eigen::MatrixXd one = ActuationForceProducts(model, pattern, x, a, directions, 1);
    EXPECT_LT(testing::RelativeError(
                  one, ForceChangeByDifferences(model, pattern, x, a, directions, 1e-5)),
              1e-7)
        << "trial " << trial;
    EXPECT_EQ(one, ActuationForceProducts(model, pattern, x, a, directions, 2));
    PolarCache cache;
    Eigen::Matrix3Xd gradient;
    model.EnergyAndGradient(x, a, &gradient, 1, &cache);
    EXPECT_EQ(one, ActuationForceProducts(model, pattern, x, a, directions, 2, &cache));
    // Column-wise linear: the product of a combination is the combination of products.
    Eigen::MatrixXd combined(directions.rows(), 1);
    combined.col(0) = 2.0 * directions.col(0) - 0.5 * directions.col(1);
    const Eigen::MatrixXd product = ActuationForceProducts(model, pattern, x, a, combined, 1);
    EXPECT_LT(testing::RelativeError(product.col(0), 2.0 * one.col(0) - 0.5 * one.col(1)),
              1e-12);
  }
  // No directions: an empty product.
  EXPECT_EQ(ActuationForceProducts(model, pattern, mesh.vertices, IdentityActuations(3),
                                   Eigen::MatrixXd(18, 0), 1)
                .cols(),
            0);
}

// A mesh of more elements than one block of the products' buffer (16,384) and than two
// grains of 256, so that the blocks and the threaded path run: the products agree with
// differenced forces, and are bit-identical for 1 and 2 threads, with a PolarCache
// filled by 2 threads too.
TEST(ActuationForceProductsTest, BlocksAndThreadsGiveTheSameProducts) {
  const TetMesh mesh = testing::BarMesh(30, 12, 10, 0.1);
  const ShapeTargetModel model(mesh, 1.0);
  ASSERT_GT(model.num_elements(), 16384);
  const BoundaryConditions bc = testing::LeftFaceFixed(mesh);
  const StiffnessPattern pattern(mesh.tets, FixedVertexMask(bc, mesh.num_vertices()));
  std::mt19937 rng(47);
  const Eigen::Matrix3Xd x = testing::JitteredVertices(mesh, 0.01, &rng);
  const ActuationMatrix a = testing::SmoothActuation(mesh, 0.3);
  const Eigen::MatrixXd directions = RandomDirections(model.num_elements(), 2, &rng);
  const Eigen::MatrixXd one = ActuationForceProducts(model, pattern, x, a, directions, 1);
  EXPECT_LT(testing::RelativeError(
                one, ForceChangeByDifferences(model, pattern, x, a, directions, 1e-5)),
            1e-7);
  EXPECT_EQ(one, ActuationForceProducts(model, pattern, x, a, directions, 2));
  PolarCache cache;
  Eigen::Matrix3Xd gradient;
  model.EnergyAndGradient(x, a, &gradient, 2, &cache);
  EXPECT_EQ(one, ActuationForceProducts(model, pattern, x, a, directions, 2, &cache));
}

}  // namespace
}  // namespace aqs
