#include "physics/polar.h"

#include <random>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <gtest/gtest.h>

#include "physics/shape_target_element.h"
#include "testing/element_states.h"
#include "testing/finite_difference.h"

namespace aqs {
namespace {

using testing::CentralDifferenceJacobian;
using testing::RelativeError;

Eigen::VectorXd RotationOf(const Eigen::VectorXd& g) {
  const Eigen::Matrix3d r =
      PolarRotation(ComputeRotationVariantSvd(UnvecRowMajor(Vector9d(g))));
  return VecRowMajor(r);
}

TEST(PolarTest, SvdIsRotationVariantAndReconstructs) {
  for (const auto& state : testing::DerivativeTestStates(5, 1)) {
    const Eigen::Matrix3d g = state.f * state.s;
    const RotationVariantSvd svd = ComputeRotationVariantSvd(g);
    EXPECT_NEAR(svd.u.determinant(), 1.0, 1e-12) << state.name;
    EXPECT_NEAR(svd.v.determinant(), 1.0, 1e-12) << state.name;
    EXPECT_GE(svd.sigma[0], svd.sigma[1]);
    EXPECT_GE(svd.sigma[1], std::abs(svd.sigma[2]) - 1e-14);
    EXPECT_LT((svd.u * svd.sigma.asDiagonal() * svd.v.transpose() - g).norm(), 1e-12 * g.norm())
        << state.name;
    const Eigen::Matrix3d r = PolarRotation(svd);
    EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
    EXPECT_EQ(svd.sigma[2] < 0, g.determinant() < 0) << state.name;
  }
}

TEST(PolarTest, RotationMaximizesTraceAgainstNearbyRotations) {
  std::mt19937 rng(7);
  for (const auto& state : testing::DerivativeTestStates(3, 2)) {
    const Eigen::Matrix3d g = state.f * state.s;
    const Eigen::Matrix3d r = PolarRotation(ComputeRotationVariantSvd(g));
    const double best = (r.transpose() * g).trace();
    for (int trial = 0; trial < 50; ++trial) {
      const Eigen::Matrix3d other = testing::RandomRotation(&rng) * r;
      EXPECT_LE((other.transpose() * g).trace(), best + 1e-12) << state.name;
    }
    // Rotations near r (turned by 1e-3 and 1e-2 about random axes), where a slightly
    // wrong r would be beaten (the trace falls quadratically in the angle): random
    // rotations alone almost never come that close.
    std::normal_distribution<double> normal(0.0, 1.0);
    for (const double angle : {1e-3, 1e-2}) {
      for (int trial = 0; trial < 20; ++trial) {
        const Eigen::Vector3d axis =
            Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
        const Eigen::Matrix3d other = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * r;
        EXPECT_LE((other.transpose() * g).trace(), best + 1e-12 * g.norm())
            << state.name << " angle " << angle;
      }
    }
  }
}

TEST(PolarTest, DerivativeMatchesFiniteDifferences) {
  for (const auto& state : testing::DerivativeTestStates(8, 3)) {
    const Eigen::Matrix3d g = state.f * state.s;
    const PolarTwists twists = ComputePolarTwists(ComputeRotationVariantSvd(g));
    Eigen::Matrix<double, 9, 9> analytic;
    for (int j = 0; j < 9; ++j) {
      analytic.col(j) = VecRowMajor(
          PolarRotationDerivative(twists, UnvecRowMajor(Vector9d::Unit(j))));
    }
    const double h = state.name.rfind("near_degenerate", 0) == 0 ? 1e-7 : 1e-5;
    const Eigen::MatrixXd numeric = CentralDifferenceJacobian(RotationOf, VecRowMajor(g), h);
    EXPECT_LT(RelativeError(analytic, numeric), 1e-6) << state.name;
  }
}

// Closer to the clamp than the shared near-degenerate states (sigma_2 + sigma_3 = 1e-3 of
// sigma_1 = 1.5 and more): sums of 1e-4 down to 3e-6 (the clamp is kPolarDegenerateRatio
// sigma_1 = 1.5e-6). The rotation turns at a rate 2 / (sigma_2 + sigma_3), up to 7e5
// here, and its derivative stays exact; differences must step well inside the gap.
TEST(PolarTest, DerivativeHoldsCloseToTheClamp) {
  std::mt19937 rng(9);
  for (const double gap : {1e-4, 1e-5, 3e-6}) {
    const Eigen::Vector3d sigma(1.5, 0.6, -(0.6 - gap));
    const Eigen::Matrix3d g = testing::RandomRotation(&rng) * sigma.asDiagonal() *
                              testing::RandomRotation(&rng).transpose();
    const RotationVariantSvd svd = ComputeRotationVariantSvd(g);
    ASSERT_NEAR(svd.sigma[1] + svd.sigma[2], gap, 1e-9) << gap;
    ASSERT_GT(svd.sigma[1] + svd.sigma[2], kPolarDegenerateRatio * svd.sigma[0]);
    const PolarTwists twists = ComputePolarTwists(svd);
    EXPECT_NEAR(twists.gain.maxCoeff(), 2.0 / gap, 1e-4 * (2.0 / gap)) << gap;
    Eigen::Matrix<double, 9, 9> analytic;
    for (int j = 0; j < 9; ++j) {
      analytic.col(j) = VecRowMajor(
          PolarRotationDerivative(twists, UnvecRowMajor(Vector9d::Unit(j))));
    }
    const Eigen::MatrixXd numeric =
        CentralDifferenceJacobian(RotationOf, VecRowMajor(g), 1e-3 * gap);
    EXPECT_LT(RelativeError(analytic, numeric), 1e-6) << "sigma_2 + sigma_3 = " << gap;
  }
}

TEST(PolarTest, ExactlyDegenerateStateIsFinite) {
  // G = diag(1, 1, -1): sigma_1 + sigma_2 = 0, the rotation is not unique.
  const Eigen::Matrix3d g = Eigen::Vector3d(1, 1, -1).asDiagonal();
  const RotationVariantSvd svd = ComputeRotationVariantSvd(g);
  EXPECT_NEAR(svd.sigma[1] + svd.sigma[2], 0.0, 1e-15);
  const PolarTwists twists = ComputePolarTwists(svd);
  EXPECT_TRUE(twists.gain.allFinite());
  EXPECT_LE(twists.gain.maxCoeff(), 2.0 / (kPolarDegenerateRatio * svd.sigma[0]) * (1 + 1e-12));
  const Eigen::Matrix3d dr = PolarRotationDerivative(twists, Eigen::Matrix3d::Ones());
  EXPECT_TRUE(dr.allFinite());
  // A collapsed element (G = 0): every gain is the floor's, 2 / (ratio x max(sigma_1, 1)).
  const PolarTwists zero = ComputePolarTwists(ComputeRotationVariantSvd(Eigen::Matrix3d::Zero()));
  for (int k = 0; k < 3; ++k) EXPECT_EQ(zero.gain[k], 2.0 / kPolarDegenerateRatio) << k;
  // Stretched beyond 1 (G = diag(3, 1, -1), sigma_2 + sigma_3 = 0): the floor scales with
  // sigma_1, so the clamped gain is 2 / (ratio x 3), not 2 / ratio.
  const RotationVariantSvd stretched =
      ComputeRotationVariantSvd(Eigen::Vector3d(3, 1, -1).asDiagonal());
  ASSERT_NEAR(stretched.sigma[0], 3.0, 1e-14);
  const PolarTwists clamped = ComputePolarTwists(stretched);
  const double expected = 2.0 / (kPolarDegenerateRatio * 3.0);
  EXPECT_NEAR(clamped.gain.maxCoeff(), expected, 1e-12 * expected);
}

}  // namespace
}  // namespace aqs
