#include "geometry/distance/triangle_quality.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <glog/logging.h>
#include <gtest/gtest.h>

#include "testing/element_states.h"
#include "testing/finite_difference.h"

namespace aqs {
namespace {

double QualityOf(const Eigen::VectorXd& v) {
  double q = 0;
  CHECK(TriangleQuality(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), &q, nullptr));
  return q;
}

Eigen::VectorXd QualityGradientOf(const Eigen::VectorXd& v) {
  double q = 0;
  Eigen::Matrix3d gradient;
  CHECK(TriangleQuality(v.segment<3>(0), v.segment<3>(3), v.segment<3>(6), &q, &gradient));
  return Eigen::Map<const Eigen::VectorXd>(gradient.data(), 9);
}

// Gradient and Hessian at random triangles, rotated ones, and nearly flat ones (the third
// corner 1e-3 of an edge off the line of the other two, quality ~1e-3).
TEST(TriangleQualityTest, GradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 30; ++trial) {
    Eigen::VectorXd x(9);
    for (int i = 0; i < 9; ++i) x[i] = normal(rng);
    if (trial % 3 == 1) {
      const Eigen::Matrix3d rotation = testing::RandomRotation(&rng);
      for (int k = 0; k < 3; ++k) x.segment<3>(3 * k) = rotation * x.segment<3>(3 * k);
    }
    if (trial % 3 == 2) {
      const Eigen::Vector3d a = x.segment<3>(0), b = x.segment<3>(3);
      const Eigen::Vector3d offset(normal(rng), normal(rng), normal(rng));
      x.segment<3>(6) = a + 0.3 * (b - a) + 1e-3 * (b - a).norm() * offset;
    }
    const double q = QualityOf(x);
    const Eigen::VectorXd gradient = QualityGradientOf(x);
    // Steps well below the flat triangles' scale of curvature (their smallest height).
    const double step = trial % 3 == 2 ? 1e-8 : 1e-6;
    EXPECT_LT(testing::RelativeError(gradient,
                                     testing::CentralDifferenceGradient(QualityOf, x, step)),
              1e-6)
        << "trial " << trial << " quality " << q;
    Eigen::Matrix<double, 9, 9> hessian;
    ASSERT_TRUE(
        TriangleQualityHessian(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), &hessian));
    const Eigen::MatrixXd differenced =
        testing::CentralDifferenceJacobian(QualityGradientOf, x, step);
    EXPECT_LT(testing::RelativeError(hessian, differenced), 1e-5)
        << "trial " << trial << " quality " << q;
    EXPECT_LT((hessian - hessian.transpose()).norm(), 1e-9 * hessian.norm());
  }
}

TEST(TriangleQualityTest, ValuesAreScaleFreeAndBounded) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0.5, std::sqrt(3.0) / 2, 0);
  double q = 0;
  ASSERT_TRUE(TriangleQuality(a, b, c, &q, nullptr));
  EXPECT_NEAR(q, 1.0 / std::sqrt(3.0), 1e-15);
  // Scaled, moved: the same; flattened: smaller, and 0 when flat.
  double moved = 0;
  const Eigen::Vector3d shift(3, -2, 7);
  ASSERT_TRUE(TriangleQuality(5 * a + shift, 5 * b + shift, 5 * c + shift, &moved, nullptr));
  EXPECT_NEAR(moved, q, 1e-14);
  double flatter = 0, flat = 0;
  ASSERT_TRUE(TriangleQuality(a, b, Eigen::Vector3d(0.5, 0.1, 0), &flatter, nullptr));
  EXPECT_LT(flatter, q);
  ASSERT_TRUE(TriangleQuality(a, b, Eigen::Vector3d(2, 0, 0), &flat, nullptr));
  EXPECT_EQ(flat, 0.0);
  // A flat triangle has no Hessian; a triangle at one point has no quality.
  Eigen::Matrix<double, 9, 9> hessian;
  EXPECT_FALSE(TriangleQualityHessian(a, b, Eigen::Vector3d(2, 0, 0), &hessian));
  EXPECT_FALSE(TriangleQuality(a, a, a, &q, nullptr));
}

}  // namespace
}  // namespace aqs
