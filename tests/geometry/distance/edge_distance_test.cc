#include "geometry/distance/edge_distance.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <glog/logging.h>
#include <gtest/gtest.h>

#include "testing/finite_difference.h"

namespace aqs {
namespace {

// The smallest sines contact passes (self_contact_pair.h: kEdgeFadeSine, kMinEdgeSine).
constexpr double kFadeSine = 0.05;
constexpr double kMinSine = 0.2;

TEST(EdgeDistanceTest, GradientAndClosestPointsMatch) {
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Eigen::VectorXd x(12);
    for (int i = 0; i < 12; ++i) x[i] = normal(rng);
    if (trial % 4 == 3) {
      // Nearly parallel edges (sine about 0.15).
      x.segment<3>(9) = x.segment<3>(6) + 1.3 * (x.segment<3>(3) - x.segment<3>(0)) +
                        0.2 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized() *
                            (x.segment<3>(3) - x.segment<3>(0)).norm();
    } else if (trial % 4 == 1) {
      // Just above the fade's lower end (sine about 0.06).
      x.segment<3>(9) = x.segment<3>(6) + 1.0 * (x.segment<3>(3) - x.segment<3>(0)) +
                        0.06 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized() *
                            (x.segment<3>(3) - x.segment<3>(0)).norm();
    }
    auto s_of = [](const Eigen::VectorXd& v) {
      double s = 0;
      CHECK(EdgeDistance(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), 0.0,
                         &s, nullptr, nullptr, nullptr));
      return s;
    };
    double s = 0, u = 0, w = 0;
    Eigen::Matrix<double, 3, 4> g;
    if (!EdgeDistance(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9),
                      kFadeSine, &s, &g, &u, &w)) {
      continue;
    }
    ++checked;
    const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(s_of, x, 1e-6);
    EXPECT_LT(testing::RelativeError(Eigen::Map<const Eigen::VectorXd>(g.data(), 12), numeric), 1e-7)
        << "trial " << trial;
    // The closest points are |s| apart, along the common normal.
    const Eigen::Vector3d p = x.segment<3>(0) + u * (x.segment<3>(3) - x.segment<3>(0));
    const Eigen::Vector3d q = x.segment<3>(6) + w * (x.segment<3>(9) - x.segment<3>(6));
    EXPECT_NEAR((p - q).norm(), std::abs(s), 1e-9);
    EXPECT_LT(std::abs((p - q).dot(x.segment<3>(3) - x.segment<3>(0))), 1e-9);
    EXPECT_LT(std::abs((p - q).dot(x.segment<3>(9) - x.segment<3>(6))), 1e-9);
  }
  EXPECT_GE(checked, 30);
  // Parallel edges are refused.
  double s = 0;
  EXPECT_FALSE(EdgeDistance(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                            Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(2, 1.01, 0), kMinSine, &s,
                            nullptr, nullptr, nullptr));
}

TEST(EdgeDistanceTest, HessianMatchesFiniteDifferences) {
  std::mt19937 rng(13);
  std::normal_distribution<double> normal;
  auto gradient = [](const Eigen::VectorXd& v) {
    double s = 0;
    Eigen::Matrix<double, 3, 4> g;
    CHECK(EdgeDistance(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), v.segment<3>(9), 0.0,
                       &s, &g, nullptr, nullptr));
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(g.data(), 12));
  };
  // Random edges, and nearly parallel ones (sine about 0.1 and 0.05).
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd x(12);
    for (int i = 0; i < 12; ++i) x[i] = normal(rng);
    if (trial % 4 == 3) {
      x.segment<3>(9) = x.segment<3>(6) + 0.9 * (x.segment<3>(3) - x.segment<3>(0)) +
                        0.1 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized() *
                            (x.segment<3>(3) - x.segment<3>(0)).norm();
    } else if (trial % 4 == 1) {  // sine about 0.05, the fade's lower end
      x.segment<3>(9) = x.segment<3>(6) + 1.0 * (x.segment<3>(3) - x.segment<3>(0)) +
                        0.05 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized() *
                            (x.segment<3>(3) - x.segment<3>(0)).norm();
    }
    Eigen::Matrix<double, 12, 12> hessian;
    ASSERT_TRUE(EdgeDistanceHessian(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6),
                                    x.segment<3>(9), &hessian));
    EXPECT_TRUE(testing::SymmetricHessianMatchesGradient(hessian, gradient, x, 1e-5, 1e-6))
        << "trial " << trial;
  }
  // Parallel edges have none.
  Eigen::Matrix<double, 12, 12> hessian;
  EXPECT_FALSE(EdgeDistanceHessian(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                                   Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(2, 1, 0), &hessian));
}

}  // namespace
}  // namespace aqs
