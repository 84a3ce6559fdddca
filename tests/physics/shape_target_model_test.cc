#include "physics/shape_target_model.h"

#include <cmath>
#include <random>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "testing/element_states.h"
#include "testing/finite_difference.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

// Two tets sharing a face, plus a third sharing an edge: small enough for dense FD.
TetMesh SmallMesh() { return testing::ThreeTetMesh(); }

ActuationMatrix RandomActuation(int n, std::mt19937* rng, double amplitude) {
  std::uniform_real_distribution<double> uniform(-amplitude, amplitude);
  ActuationMatrix a = IdentityActuations(n);
  for (int e = 0; e < n; ++e) {
    for (int k = 0; k < 6; ++k) a(k, e) += uniform(*rng);
  }
  return a;
}

// SmallMesh with a different stiffness per element.
ShapeTargetModel SmallModel() {
  Eigen::VectorXd mu(3);
  mu << 1.0, 2.5, 0.7;
  return ShapeTargetModel(SmallMesh(), mu);
}

TEST(ShapeTargetModelTest, GradientMatchesFiniteDifferences) {
  const TetMesh mesh = SmallMesh();
  const ShapeTargetModel model = SmallModel();
  std::mt19937 rng(21);
  std::normal_distribution<double> normal(0.0, 0.15);
  for (int trial = 0; trial < 5; ++trial) {
    const ActuationMatrix a = RandomActuation(3, &rng, 0.3);
    Eigen::Matrix3Xd x = testing::RandomRotation(&rng) * mesh.vertices;
    for (int i = 0; i < x.size(); ++i) x.data()[i] += normal(rng);
    Eigen::Matrix3Xd gradient;
    const double energy = model.EnergyAndGradient(x, a, &gradient, 2);
    EXPECT_NEAR(energy, model.Energy(x, a, 1), 1e-12 * energy);
    auto f = [&](const Eigen::VectorXd& flat) {
      return model.Energy(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, 6), a);
    };
    const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(
        f, Eigen::Map<const Eigen::VectorXd>(x.data(), x.size()), 1e-6);
    EXPECT_LT(testing::RelativeError(
                  Eigen::Map<const Eigen::VectorXd>(gradient.data(), gradient.size()), numeric),
              1e-7);
  }
}

// dE/da at fixed x against central differences over all 18 actuation numbers: random
// deformations with random rotations, and one element nearly flat (its fourth vertex
// 1e-3 from the plane of the other three).
TEST(ShapeTargetModelTest, ActuationGradientMatchesFiniteDifferences) {
  const ShapeTargetModel model = SmallModel();
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 0.15);
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::Matrix3Xd x = SmallMesh().vertices;
    const ActuationMatrix a = RandomActuation(3, &rng, 0.3);
    if (trial == 4) {  // tet 0 = (0, 1, 2, 3): vertex 3 almost onto the plane z = 0
      x(2, 3) = 1e-3;
    } else {
      for (int i = 0; i < x.size(); ++i) x.data()[i] += normal(rng);
    }
    x = testing::RandomRotation(&rng) * x;
    ActuationMatrix gradient;
    const double energy = model.EnergyActuationGradient(x, a, &gradient, 2);
    EXPECT_NEAR(energy, model.Energy(x, a, 1), 1e-12 * energy);
    ASSERT_EQ(gradient.cols(), 3);
    // The same from the SVDs an energy evaluation at (x, a) cached.
    PolarCache cache;
    Eigen::Matrix3Xd dx;
    model.EnergyAndGradient(x, a, &dx, 1, &cache);
    ActuationMatrix cached;
    EXPECT_NEAR(model.EnergyActuationGradient(x, a, &cached, 1, &cache), energy, 1e-12 * energy);
    EXPECT_LT((cached - gradient).cwiseAbs().maxCoeff(), 1e-12 * gradient.cwiseAbs().maxCoeff());
    auto f = [&](const Eigen::VectorXd& flat) {
      return model.Energy(x, Eigen::Map<const ActuationMatrix>(flat.data(), 6, 3));
    };
    const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(
        f, Eigen::Map<const Eigen::VectorXd>(a.data(), a.size()), 1e-6);
    EXPECT_LT(testing::RelativeError(
                  Eigen::Map<const Eigen::VectorXd>(gradient.data(), gradient.size()), numeric),
              1e-7)
        << "trial " << trial;
  }
}

TEST(ShapeTargetModelTest, RestIsEquilibriumAndRigidMotionsAreFree) {
  const TetMesh mesh = SmallMesh();
  const ShapeTargetModel model(mesh, 3.0);
  const ActuationMatrix identity = IdentityActuations(3);
  Eigen::Matrix3Xd gradient;
  EXPECT_NEAR(model.EnergyAndGradient(mesh.vertices, identity, &gradient), 0.0, 1e-28);
  EXPECT_LT(gradient.norm(), 1e-13);
  std::mt19937 rng(2);
  std::mt19937 rng_a(3);
  const ActuationMatrix a = RandomActuation(3, &rng_a, 0.3);
  const Eigen::Matrix3d r = testing::RandomRotation(&rng);
  const Eigen::Vector3d t(0.3, -2.0, 5.0);
  const Eigen::Matrix3Xd moved = (r * mesh.vertices).colwise() + t;
  EXPECT_NEAR(model.Energy(moved, identity), 0.0, 1e-26);
  // A rigid motion of any deformed state keeps its energy (frame indifference).
  Eigen::Matrix3Xd deformed = mesh.vertices;
  deformed(0, 4) += 0.3;
  deformed(2, 5) -= 0.2;
  const double e = model.Energy(deformed, a);
  EXPECT_NEAR(model.Energy((r * deformed).colwise() + t, a), e, 1e-12 * e);
}

TEST(ShapeTargetModelTest, ForceScaleAndVolume) {
  const TetMesh mesh = SmallMesh();
  const ShapeTargetModel model(mesh, 2.0);
  double volume = 0;
  for (int e = 0; e < 3; ++e) volume += model.rest_shape(e).volume;
  EXPECT_NEAR(model.total_volume(), volume, 1e-15);
  EXPECT_NEAR(model.rest_shape(0).volume, 1.0 / 6.0, 1e-15);
  EXPECT_GT(model.force_scale(), 0.0);
}

// E = sum_e V_e Psi_e(F_e, S_e, mu_e) with each element's own mu, recomputed from the
// vertices (F_e = Ds Dm^-1), equals what Energy, EnergyAndGradient (with and without a
// polar cache) and EnergyActuationGradient return.
TEST(ShapeTargetModelTest, EnergyIsTheVolumeWeightedSumOfDensitiesWithEachElementsMu) {
  const TetMesh mesh = SmallMesh();
  const ShapeTargetModel model = SmallModel();
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 0.1);
  const ActuationMatrix a = RandomActuation(3, &rng, 0.3);
  Eigen::Matrix3Xd x = mesh.vertices;
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += normal(rng);
  double expected = 0.0;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    Eigen::Matrix3d rest, deformed;
    for (int k = 0; k < 3; ++k) {
      rest.col(k) = mesh.vertices.col(mesh.tets(k + 1, e)) - mesh.vertices.col(mesh.tets(0, e));
      deformed.col(k) = x.col(mesh.tets(k + 1, e)) - x.col(mesh.tets(0, e));
    }
    const Eigen::Matrix3d f = deformed * rest.inverse();
    const double volume = std::abs(rest.determinant()) / 6.0;
    expected += volume * ShapeTargetElement(f, SymmetricFromActuation(a.col(e).data()), model.mu(e))
                             .EnergyDensity();
  }
  EXPECT_NEAR(model.Energy(x, a, 1), expected, 1e-12 * expected);
  Eigen::Matrix3Xd gradient;
  EXPECT_NEAR(model.EnergyAndGradient(x, a, &gradient, 2), expected, 1e-12 * expected);
  PolarCache cache;
  EXPECT_NEAR(model.EnergyAndGradient(x, a, &gradient, 1, &cache), expected, 1e-12 * expected);
  EXPECT_NEAR(model.EnergyAndGradient(x, a, &gradient, 1, &cache), expected, 1e-12 * expected);
  ActuationMatrix da;
  EXPECT_NEAR(model.EnergyActuationGradient(x, a, &da, 1), expected, 1e-12 * expected);
}

// The documented scales, recomputed from the mesh's own vertices with a stiffness that
// differs per element (with mu = 1 everywhere, sum mu V = sum V hides a dropped mu).
TEST(ShapeTargetModelTest, StiffnessVolumeAndForceScaleFollowTheirFormulas) {
  const TetMesh mesh = SmallMesh();
  const ShapeTargetModel model = SmallModel();
  double volume = 0.0;
  double stiffness_volume = 0.0;
  double scale_sum = 0.0;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    Eigen::Matrix3d edges;
    for (int k = 0; k < 3; ++k) {
      edges.col(k) = mesh.vertices.col(mesh.tets(k + 1, e)) - mesh.vertices.col(mesh.tets(0, e));
    }
    const double v = std::abs(edges.determinant()) / 6.0;
    volume += v;
    stiffness_volume += model.mu(e) * v;
    scale_sum += model.mu(e) * std::pow(v, 2.0 / 3.0);
  }
  EXPECT_NEAR(model.total_volume(), volume, 1e-14 * volume);
  EXPECT_NEAR(model.stiffness_volume(), stiffness_volume, 1e-14 * stiffness_volume);
  const double force_scale = 2.0 * scale_sum / mesh.num_tets();
  EXPECT_NEAR(model.force_scale(), force_scale, 1e-14 * force_scale);
}

}  // namespace
}  // namespace aqs
