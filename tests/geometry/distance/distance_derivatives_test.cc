#include "geometry/distance/distance_derivatives.h"

#include <random>

#include <Eigen/Geometry>
#include <glog/logging.h>
#include <gtest/gtest.h>

#include "geometry/distance/plane_distance.h"
#include "testing/finite_difference.h"

namespace aqs {
namespace {

TEST(CrossProductMatrixTest, MultipliesAsTheCrossProduct) {
  const Eigen::Vector3d a(0.3, -1.2, 2.0), b(-0.7, 0.4, 1.1);
  EXPECT_LT((CrossProductMatrix(a) * b - a.cross(b)).norm(), 1e-15);
}

// f = unit(u x v) . w is the plane distance of p = w from the triangle (0, u, v), whose
// gradient with respect to (p, b, c) is df/d(w, u, v).
TEST(UnitCrossDotHessianTest, MatchesFiniteDifferencesOfTheGradient) {
  std::mt19937 rng(21);
  std::normal_distribution<double> normal;
  auto gradient = [](const Eigen::VectorXd& uvw) {
    double s = 0;
    Eigen::Matrix<double, 3, 4> g;
    CHECK(PlaneDistance(uvw.segment<3>(6), Eigen::Vector3d::Zero(), uvw.segment<3>(0),
                        uvw.segment<3>(3), &s, &g, nullptr));
    Eigen::VectorXd flat(9);
    flat << g.col(2), g.col(3), g.col(0);  // u, v, w
    return flat;
  };
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd uvw(9);
    for (int i = 0; i < 9; ++i) uvw[i] = normal(rng);
    Eigen::Matrix<double, 9, 9> hessian;
    ASSERT_TRUE(UnitCrossDotHessian(uvw.segment<3>(0), uvw.segment<3>(3), uvw.segment<3>(6),
                                    &hessian));
    EXPECT_LT(testing::RelativeError(hessian, testing::CentralDifferenceJacobian(gradient, uvw, 1e-5)),
              1e-6)
        << "trial " << trial;
  }
  Eigen::Matrix<double, 9, 9> hessian;
  const Eigen::Vector3d u(1, 2, 3);
  EXPECT_FALSE(UnitCrossDotHessian(u, 2 * u, Eigen::Vector3d(0, 0, 1), &hessian));
}

// Scattering the Hessian of f(d) = d^T A d / 2 over a difference d = p1 - p0 gives the
// Hessian of f(p1 - p0) with respect to the four points.
TEST(ScatterDifferenceHessianTest, ChainsDifferencesToPoints) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Random();
  a = (a + a.transpose()).eval();
  Eigen::Matrix<double, 1, 4> coefficients;
  coefficients << -1, 1, 0, 0;
  Eigen::Matrix<double, 12, 12> hessian;
  ScatterDifferenceHessian<1>(coefficients, a, &hessian);
  Eigen::Matrix<double, 12, 12> expected = Eigen::Matrix<double, 12, 12>::Zero();
  expected.block<3, 3>(0, 0) = a;
  expected.block<3, 3>(3, 3) = a;
  expected.block<3, 3>(0, 3) = -a;
  expected.block<3, 3>(3, 0) = -a;
  EXPECT_EQ(hessian, expected);
}

}  // namespace
}  // namespace aqs
