#include "contact/self_contact_pair.h"

#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <glog/logging.h>
#include <gtest/gtest.h>

#include "testing/finite_difference.h"

namespace aqs {
namespace {

TEST(SelfContactDistanceTest, HessianMatchesFiniteDifferences) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 1.0);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(2.3, Eigen::Vector3d(-0.2, 0.9, 0.4).normalized()).toRotationMatrix();
  for (const SelfContactPair::Kind kind :
       {SelfContactPair::Kind::kPointTriangle, SelfContactPair::Kind::kEdgeEdge}) {
    SelfContactPair pair;
    pair.kind = kind;
    pair.sign = kind == SelfContactPair::Kind::kEdgeEdge ? -1.0 : 1.0;
    // Random states; rotated; near-degenerate (a thin triangle, nearly parallel edges).
    std::vector<Eigen::Matrix<double, 3, 4>> states;
    for (int trial = 0; trial < 4; ++trial) {
      Eigen::Matrix<double, 3, 4> points;
      for (int k = 0; k < 12; ++k) points(k) = noise(rng);
      states.push_back(points);
      states.push_back(rotation * points);
    }
    Eigen::Matrix<double, 3, 4> thin;
    if (kind == SelfContactPair::Kind::kPointTriangle) {
      thin << 0.3, 0, 1, 0.5, 0.2, 0, 0, 0.02, 0.4, 0, 0.01, 0;  // corners nearly collinear
    } else {
      thin << 0, 1, 0.1, 1.1, 0, 0.02, 0.1, 0.1 - 0.02, 0, 0.01, -0.3, -0.3;  // sine ~0.04
    }
    states.push_back(thin);
    for (const Eigen::Matrix<double, 3, 4>& state : states) {
      const Eigen::Vector3d points[4] = {state.col(0), state.col(1), state.col(2), state.col(3)};
      Eigen::Matrix<double, 12, 12> hessian;
      ASSERT_TRUE(SelfContactDistanceHessian(pair, points, &hessian));
      auto gradient = [&](const Eigen::VectorXd& flat) {
        const Eigen::Vector3d p[4] = {flat.segment<3>(0), flat.segment<3>(3), flat.segment<3>(6),
                                      flat.segment<3>(9)};
        double s = 0, outside = 0;
        Eigen::Matrix<double, 3, 4> g;
        CHECK(SelfContactDistance(pair, p, &s, &g, &outside));
        return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(g.data(), 12));
      };
      EXPECT_TRUE(testing::SymmetricHessianMatchesGradient(
          hessian, gradient, Eigen::Map<const Eigen::VectorXd>(state.data(), 12), 1e-5, 1e-6))
          << (kind == SelfContactPair::Kind::kEdgeEdge ? "edge-edge" : "point-triangle") << "\n"
          << state;
    }
  }
}

TEST(SelfContactPairTest, SquashedTrianglesAreNotPaired) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0);
  EXPECT_TRUE(PairableTriangle(a, b, Eigen::Vector3d(0.5, 0.8, 0)));
  // Quality about 4 h / 3 for height h over the unit base: 0.04 and 0.027.
  EXPECT_TRUE(PairableTriangle(a, b, Eigen::Vector3d(0.5, 0.03, 0.01)));
  EXPECT_FALSE(PairableTriangle(a, b, Eigen::Vector3d(0.5, 0.02, 0)));
  EXPECT_FALSE(PairableTriangle(a, b, Eigen::Vector3d(0.5, 0, 0)));
  EXPECT_FALSE(PairableTriangle(a, a, a));
}

}  // namespace
}  // namespace aqs
