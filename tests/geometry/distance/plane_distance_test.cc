#include "geometry/distance/plane_distance.h"

#include <random>

#include <Eigen/Geometry>
#include <glog/logging.h>
#include <gtest/gtest.h>

#include "testing/finite_difference.h"

namespace aqs {
namespace {

TEST(PlaneDistanceTest, GradientMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  // Random triangles, and thin ones (corners nearly collinear: quality about 0.01, where
  // contact's fade of thin triangles begins).
  for (int trial = 0; trial < 24; ++trial) {
    Eigen::VectorXd x(12);
    for (int i = 0; i < 12; ++i) x[i] = normal(rng);
    if (trial % 4 == 3) {
      x.segment<3>(9) = 0.5 * (x.segment<3>(3) + x.segment<3>(6)) +
                        0.01 * (x.segment<3>(6) - x.segment<3>(3)).norm() *
                            Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    }
    auto s_of = [](const Eigen::VectorXd& v) {
      double s = 0;
      PlaneDistance(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), &s,
                    nullptr, nullptr);
      return s;
    };
    double s = 0;
    Eigen::Matrix<double, 3, 4> g;
    Eigen::Vector3d beta;
    ASSERT_TRUE(PlaneDistance(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9), &s,
                              &g, &beta));
    const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(s_of, x, 1e-6);
    EXPECT_LT(testing::RelativeError(Eigen::Map<const Eigen::VectorXd>(g.data(), 12), numeric),
              1e-8)
        << "trial " << trial;
    // The projection is reproduced by the barycentric coordinates.
    const Eigen::Vector3d a = x.segment<3>(3), b = x.segment<3>(6), c = x.segment<3>(9);
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    EXPECT_LT((beta[0] * a + beta[1] * b + beta[2] * c - (x.segment<3>(0) - s * n)).norm(), 1e-10);
  }
}

TEST(PlaneDistanceTest, HessianMatchesFiniteDifferences) {
  std::mt19937 rng(4);
  std::normal_distribution<double> normal;
  auto gradient = [](const Eigen::VectorXd& v) {
    double s = 0;
    Eigen::Matrix<double, 3, 4> g;
    CHECK(PlaneDistance(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), &s,
                        &g, nullptr));
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(g.data(), 12));
  };
  // Random triangles, and thin ones (corners nearly collinear).
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd x(12);
    for (int i = 0; i < 12; ++i) x[i] = normal(rng);
    if (trial % 4 == 3) {
      x.segment<3>(9) = 0.5 * (x.segment<3>(3) + x.segment<3>(6)) +
                        0.05 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    }
    Eigen::Matrix<double, 12, 12> hessian;
    ASSERT_TRUE(PlaneDistanceHessian(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6),
                                     x.segment<3>(9), &hessian));
    EXPECT_TRUE(testing::SymmetricHessianMatchesGradient(hessian, gradient, x, 1e-5, 1e-6))
        << "trial " << trial;
  }
  // A degenerate triangle has none.
  Eigen::Matrix<double, 12, 12> hessian;
  const Eigen::Vector3d o(0, 0, 0), x(1, 0, 0);
  EXPECT_FALSE(PlaneDistanceHessian(Eigen::Vector3d(0, 0, 1), o, x, 2 * x, &hessian));
}

}  // namespace
}  // namespace aqs
