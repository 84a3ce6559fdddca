#include "physics/shape_target_element.h"

#include <random>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "physics/actuation.h"
#include "testing/element_states.h"
#include "testing/finite_difference.h"

namespace aqs {
namespace {

using testing::CentralDifferenceGradient;
using testing::CentralDifferenceJacobian;
using testing::RelativeError;

constexpr double kMu = 1.7;

double StepFor(const testing::ElementState& state) {
  return state.name.rfind("near_degenerate", 0) == 0 ? 1e-7 : 1e-5;
}

TEST(ShapeTargetElementTest, EnergyMatchesSingularValueFormula) {
  for (const auto& state : testing::DerivativeTestStates(5, 11)) {
    const ShapeTargetElement element(state.f, state.s, kMu);
    const double via_svd = kMu * (state.f.squaredNorm() + state.s.squaredNorm() -
                                  2.0 * element.svd().sigma.sum());
    EXPECT_NEAR(element.EnergyDensity(), via_svd, 1e-12 * (1 + std::abs(via_svd))) << state.name;
    EXPECT_GE(element.EnergyDensity(), 0.0);
  }
}

TEST(ShapeTargetElementTest, RestAndRigidStatesCostNothing) {
  std::mt19937 rng(5);
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d r = testing::RandomRotation(&rng);
  EXPECT_NEAR(ShapeTargetElement(identity, identity, kMu).EnergyDensity(), 0.0, 1e-28);
  EXPECT_NEAR(ShapeTargetElement(r, identity, kMu).EnergyDensity(), 0.0, 1e-26);
  // F = R S costs nothing for any symmetric positive definite S.
  const Eigen::Matrix3d s = (Eigen::Matrix3d() << 1.3, 0.2, 0.1, 0.2, 0.8, -0.1, 0.1, -0.1, 1.1)
                                .finished();
  const ShapeTargetElement target(r * s, s, kMu);
  EXPECT_NEAR(target.EnergyDensity(), 0.0, 1e-24);
  EXPECT_LT(target.Stress().norm(), 1e-12);
}

TEST(ShapeTargetElementTest, StressIsEnergyGradient) {
  for (const auto& state : testing::DerivativeTestStates(6, 12)) {
    const ShapeTargetElement element(state.f, state.s, kMu);
    auto energy = [&](const Eigen::VectorXd& f) {
      return ShapeTargetElement(UnvecRowMajor(Vector9d(f)), state.s, kMu).EnergyDensity();
    };
    const Eigen::VectorXd numeric =
        CentralDifferenceGradient(energy, VecRowMajor(state.f), StepFor(state));
    EXPECT_LT(RelativeError(VecRowMajor(element.Stress()), numeric), 1e-7) << state.name;
  }
}

TEST(ShapeTargetElementTest, StressDerivativeMatchesFiniteDifferences) {
  for (const auto& state : testing::DerivativeTestStates(6, 13)) {
    const ShapeTargetElement element(state.f, state.s, kMu);
    auto stress = [&](const Eigen::VectorXd& f) -> Eigen::VectorXd {
      return VecRowMajor(ShapeTargetElement(UnvecRowMajor(Vector9d(f)), state.s, kMu).Stress());
    };
    const Eigen::MatrixXd numeric =
        CentralDifferenceJacobian(stress, VecRowMajor(state.f), StepFor(state));
    const Matrix9d analytic = element.StressDerivative();
    EXPECT_LT(RelativeError(analytic, numeric), 1e-6) << state.name;
    EXPECT_LT((analytic - analytic.transpose()).norm(), 1e-12 * analytic.norm()) << state.name;
  }
}

TEST(ShapeTargetElementTest, ProjectedStressDerivativeIsEigenClampOfExact) {
  int indefinite_cases = 0;
  for (const auto& state : testing::DerivativeTestStates(6, 14)) {
    const ShapeTargetElement element(state.f, state.s, kMu);
    const Matrix9d exact = element.StressDerivative();
    Eigen::SelfAdjointEigenSolver<Matrix9d> eig(exact);
    const Vector9d clamped = eig.eigenvalues().cwiseMax(0.0);
    const Matrix9d reference =
        eig.eigenvectors() * clamped.asDiagonal() * eig.eigenvectors().transpose();
    const Matrix9d projected = element.ProjectedStressDerivative();
    EXPECT_LT(RelativeError(projected, reference), 1e-9) << state.name;
    Eigen::SelfAdjointEigenSolver<Matrix9d> projected_eig(projected);
    EXPECT_GE(projected_eig.eigenvalues().minCoeff(), -1e-10 * exact.norm()) << state.name;
    if (eig.eigenvalues().minCoeff() < -1e-9) ++indefinite_cases;
  }
  EXPECT_GT(indefinite_cases, 3) << "the states should exercise the projection";
}

TEST(ShapeTargetElementTest, EnergyActuationGradientMatchesFiniteDifferences) {
  for (const auto& state : testing::DerivativeTestStates(6, 15)) {
    const ShapeTargetElement element(state.f, state.s, kMu);
    auto energy = [&](const Eigen::VectorXd& a) {
      return ShapeTargetElement(state.f, SymmetricFromActuation(a.data()), kMu).EnergyDensity();
    };
    const Eigen::VectorXd numeric = CentralDifferenceGradient(
        energy, ActuationFromSymmetric(state.s), StepFor(state));
    EXPECT_LT(RelativeError(element.EnergyActuationGradient(), numeric), 1e-7) << state.name;
  }
}

TEST(ShapeTargetElementTest, StressActuationDerivativeMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  for (const auto& state : testing::DerivativeTestStates(6, 16)) {
    const ShapeTargetElement element(state.f, state.s, kMu);
    auto stress = [&](const Eigen::VectorXd& a) -> Eigen::VectorXd {
      return VecRowMajor(
          ShapeTargetElement(state.f, SymmetricFromActuation(a.data()), kMu).Stress());
    };
    const Eigen::MatrixXd numeric =
        CentralDifferenceJacobian(stress, ActuationFromSymmetric(state.s), StepFor(state));
    const Matrix96d analytic = element.StressActuationDerivative();
    EXPECT_LT(RelativeError(analytic, numeric), 1e-6) << state.name;
    // The adjoint product and the directional form agree with the matrix.
    Eigen::Matrix3d x;
    for (int i = 0; i < 9; ++i) x.data()[i] = normal(rng);
    const Vector6d adjoint = element.StressActuationAdjoint(x);
    const Vector6d via_matrix = analytic.transpose() * VecRowMajor(x);
    EXPECT_LT(RelativeError(adjoint, via_matrix), 1e-12) << state.name;
    Vector6d direction;
    for (int i = 0; i < 6; ++i) direction[i] = normal(rng);
    const Eigen::Matrix3d directional =
        element.StressActuationDirectional(SymmetricFromActuation(direction.data()));
    EXPECT_LT(RelativeError(VecRowMajor(directional), analytic * direction), 1e-12)
        << state.name;
  }
}

TEST(ShapeTargetElementTest, DegenerateAndCollapsedStatesAreFinite) {
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const std::vector<Eigen::Matrix3d> fs = {
      Eigen::Vector3d(1, 1, -1).asDiagonal(),  // sigma_1 + sigma_2 = 0 exactly
      Eigen::Vector3d(1, 0, 0).asDiagonal(),   // flattened to a line
      Eigen::Matrix3d::Zero(),                 // collapsed to a point
      -identity,                               // fully inverted
  };
  for (const Eigen::Matrix3d& f : fs) {
    const ShapeTargetElement element(f, identity, kMu);
    EXPECT_TRUE(std::isfinite(element.EnergyDensity()));
    EXPECT_TRUE(element.Stress().allFinite());
    EXPECT_TRUE(element.StressDerivative().allFinite());
    EXPECT_TRUE(element.ProjectedStressDerivative().allFinite());
    EXPECT_TRUE(element.StressActuationDerivative().allFinite());
    EXPECT_TRUE(element.EnergyActuationGradient().allFinite());
    Eigen::SelfAdjointEigenSolver<Matrix9d> eig(element.ProjectedStressDerivative());
    EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-6 * eig.eigenvalues().cwiseAbs().maxCoeff());
    // Bounded, not only finite: the polar gains are at most 2 / kPolarDegenerateRatio
    // (the element collapsed to a point had entries of 2e106 before 2026-12-07).
    EXPECT_LT(element.StressDerivative().cwiseAbs().maxCoeff(),
              4.0 * kMu / kPolarDegenerateRatio);
  }
  // The energy is continuous across the degenerate state: nearby states give nearby values.
  const Eigen::Matrix3d f0 = Eigen::Vector3d(1, 1, -1).asDiagonal();
  const double e0 = ShapeTargetElement(f0, identity, kMu).EnergyDensity();
  Eigen::Matrix3d df;
  df << 0.3, -0.2, 0.5, 0.1, 0.4, -0.7, 0.2, 0.6, 0.1;
  for (double t : {1e-4, 1e-6, 1e-8}) {
    const double e = ShapeTargetElement(f0 + t * df, identity, kMu).EnergyDensity();
    EXPECT_NEAR(e, e0, 100 * t);
  }
}

}  // namespace
}  // namespace aqs
