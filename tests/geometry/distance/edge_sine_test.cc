#include "geometry/distance/edge_sine.h"

#include <random>

#include <Eigen/Geometry>
#include <glog/logging.h>
#include <gtest/gtest.h>

#include "testing/finite_difference.h"

namespace aqs {
namespace {

// The sine's gradient and Hessian at random edges and at nearly parallel ones.
TEST(EdgeSineTest, GradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(6);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd x(12);
    for (int i = 0; i < 12; ++i) x[i] = normal(rng);
    if (trial % 2 == 1) {
      x.segment<3>(9) = x.segment<3>(6) + 0.8 * (x.segment<3>(3) - x.segment<3>(0)) +
                        0.1 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    }
    auto sine_of = [](const Eigen::VectorXd& v) {
      double sine = 0;
      CHECK(EdgeSine(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), &sine,
                     nullptr));
      return sine;
    };
    double sine = 0;
    Eigen::Matrix<double, 3, 4> g;
    ASSERT_TRUE(EdgeSine(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9), &sine,
                         &g));
    const Eigen::Vector3d e1 = x.segment<3>(3) - x.segment<3>(0), e2 = x.segment<3>(9) - x.segment<3>(6);
    EXPECT_NEAR(sine, e1.cross(e2).norm() / (e1.norm() * e2.norm()), 1e-14);
    EXPECT_LT(testing::RelativeError(Eigen::Map<const Eigen::VectorXd>(g.data(), 12),
                                     testing::CentralDifferenceGradient(sine_of, x, 1e-6)),
              1e-7)
        << "trial " << trial << " sine " << sine;
    // And its Hessian, against differences of that gradient.
    auto sine_gradient = [](const Eigen::VectorXd& v) {
      double sine = 0;
      Eigen::Matrix<double, 3, 4> gradient;
      CHECK(EdgeSine(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), &sine,
                     &gradient));
      return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(gradient.data(), 12));
    };
    Eigen::Matrix<double, 12, 12> hessian;
    ASSERT_TRUE(EdgeSineHessian(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9),
                                &hessian));
    EXPECT_LT(testing::RelativeError(hessian, testing::CentralDifferenceJacobian(sine_gradient, x, 1e-5)),
              1e-6)
        << "trial " << trial << " sine " << sine;
  }
}

TEST(EdgeSineTest, DegenerateEdgesAreRefused) {
  const Eigen::Vector3d o(0, 0, 0), x(1, 0, 0), y(0, 1, 0);
  double sine = 0;
  EXPECT_FALSE(EdgeSine(o, o, o, y, &sine, nullptr));
  EXPECT_FALSE(EdgeSine(o, x, y, y, &sine, nullptr));
  // Parallel edges have a sine (0) but no Hessian.
  ASSERT_TRUE(EdgeSine(o, x, y, Eigen::Vector3d(2, 1, 0), &sine, nullptr));
  EXPECT_EQ(sine, 0.0);
  Eigen::Matrix<double, 12, 12> hessian;
  EXPECT_FALSE(EdgeSineHessian(o, x, y, Eigen::Vector3d(2, 1, 0), &hessian));
}

}  // namespace
}  // namespace aqs
