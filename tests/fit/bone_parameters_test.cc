#include "fit/bone_parameters.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "testing/finite_difference.h"

namespace aqs {
namespace {

// R(omega) X by the parameterization's own transform, for finite differences.
Eigen::Vector3d Rotated(const Eigen::Vector3d& omega, const Eigen::Vector3d& point) {
  const double parameters[6] = {omega[0], omega[1], omega[2], 0, 0, 0};
  return BoneTransformFromParameters(parameters).rotation * point;
}

TEST(BoneParametersTest, RotatedPointJacobianMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector3d point(0.3, -8.0, 10.0);  // a chin, 13 units from the origin
  // Random rotations, a large one, and near-degenerate ones (tiny and zero angles,
  // where the rotation vector's axis is undefined).
  std::vector<Eigen::Vector3d> omegas = {Eigen::Vector3d(0.7, -1.2, 2.0),
                                         Eigen::Vector3d(1e-9, -2e-9, 0.5e-9),
                                         Eigen::Vector3d::Zero()};
  for (int i = 0; i < 4; ++i) {
    omegas.push_back(0.3 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng)));
  }
  for (const Eigen::Vector3d& omega : omegas) {
    const Eigen::Matrix3d analytic = RotatedPointJacobian(omega.data(), point);
    const Eigen::MatrixXd numeric = testing::CentralDifferenceJacobian(
        [&](const Eigen::VectorXd& w) -> Eigen::VectorXd { return Rotated(w, point); }, omega,
        1e-5);
    EXPECT_LT(testing::RelativeError(analytic, numeric), 1e-8)
        << "omega " << omega.transpose() << "\nanalytic\n" << analytic << "\nnumeric\n"
        << numeric;
  }
  // At rest the derivative is the cross-product matrix: d(omega x X) = -[X]x d omega.
  const Eigen::Vector3d rest = Eigen::Vector3d::Zero();
  const Eigen::Matrix3d at_rest = RotatedPointJacobian(rest.data(), point);
  Eigen::Matrix3d cross;
  cross << 0, point.z(), -point.y(), -point.z(), 0, point.x(), point.y(), -point.x(), 0;
  EXPECT_LT((at_rest - cross).norm(), 1e-14) << at_rest;
}

TEST(BoneParametersTest, TransformAndParametersRoundTrip) {
  const double parameters[6] = {0.2, -0.4, 1.1, 0.5, -3.0, 2.0};
  const RigidTransform t = BoneTransformFromParameters(parameters);
  EXPECT_LT((t.rotation * t.rotation.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  double back[6];
  BoneTransformToParameters(t, back);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(back[i], parameters[i], 1e-12) << i;
  // Zero is the identity.
  const double zero[6] = {0, 0, 0, 0, 0, 0};
  const RigidTransform rest = BoneTransformFromParameters(zero);
  EXPECT_EQ(rest.rotation, Eigen::Matrix3d::Identity());
  EXPECT_EQ(rest.translation, Eigen::Vector3d::Zero());
}

}  // namespace
}  // namespace aqs
