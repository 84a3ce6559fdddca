#include "contact/self_contact_pair.h"

#include <cmath>
#include <random>
#include <utility>
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

// The fade variable (EdgeSine of the two edges, or TriangleQuality of the corners with a
// zero column for the point) as the pair sees it: its gradient against differences of its
// value and its Hessian against differences of its gradient, at random and rotated states
// and at both ends of each fade band (sine 0.06 and 0.14; quality 0.012 and 0.018), where
// the weight's smoothstep begins and ends.
TEST(SelfContactFadeVariableTest, GradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(13);
  std::normal_distribution<double> noise(0.0, 1.0);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.5, -0.3, 0.8).normalized()).toRotationMatrix();
  for (const SelfContactPair::Kind kind :
       {SelfContactPair::Kind::kPointTriangle, SelfContactPair::Kind::kEdgeEdge}) {
    const bool edges = kind == SelfContactPair::Kind::kEdgeEdge;
    SelfContactPair pair;
    pair.kind = kind;
    pair.sign = edges ? -1.0 : 1.0;
    const SelfContactFadeBand band = FadeBandOf(pair);
    EXPECT_EQ(band.zero, edges ? kEdgeFadeSine : kTriangleFadeQuality);
    EXPECT_EQ(band.full, edges ? kFullEdgeSine : kFullTriangleQuality);
    std::vector<std::pair<Eigen::Matrix<double, 3, 4>, double>> states;  // state, f or -1
    for (int trial = 0; trial < 3; ++trial) {
      Eigen::Matrix<double, 3, 4> points;
      for (int k = 0; k < 12; ++k) points(k) = noise(rng);
      states.push_back({points, -1.0});
      states.push_back({rotation * points, -1.0});
    }
    for (const double f : {band.zero + 0.2 * (band.full - band.zero),
                           band.full - 0.2 * (band.full - band.zero)}) {
      Eigen::Matrix<double, 3, 4> points;
      if (edges) {  // pa, pb along x; qa, qb at angle asin(f) to it, 0.3 above
        const double c = std::sqrt(1 - f * f);
        points << 0, 1, 0.2, 0.2 + 1.1 * c, 0, 0, -0.1, -0.1 + 1.1 * f, 0, 0, 0.3, 0.3;
      } else {  // a point above the triangle (0, 0, 0), (1, 0, 0), (0.5, h, 0) of quality f
        const double h = 0.75 * f;  // q = 2h / (1.5 + 2h^2) = f to O(f^3)
        points << 0.4, 0, 1, 0.5, 0.1, 0, 0, h, 0.2, 0, 0, 0;
      }
      points = rotation * points;
      states.push_back({points, f});
    }
    for (const auto& [state, band_value] : states) {
      const Eigen::Vector3d points[4] = {state.col(0), state.col(1), state.col(2), state.col(3)};
      double value = 0;
      Eigen::Matrix<double, 3, 4> gradient;
      ASSERT_TRUE(SelfContactFadeVariable(pair, points, &value, &gradient));
      if (band_value > 0) {
        EXPECT_NEAR(value, band_value, 1e-3 * band_value);
      }
      if (!edges) {
        EXPECT_EQ(gradient.col(0).norm(), 0.0) << "the point does not shape the fade";
      }
      auto value_at = [&](const Eigen::VectorXd& flat) {
        const Eigen::Vector3d p[4] = {flat.segment<3>(0), flat.segment<3>(3), flat.segment<3>(6),
                                      flat.segment<3>(9)};
        double f = 0;
        CHECK(SelfContactFadeVariable(pair, p, &f, nullptr));
        return f;
      };
      auto gradient_at = [&](const Eigen::VectorXd& flat) {
        const Eigen::Vector3d p[4] = {flat.segment<3>(0), flat.segment<3>(3), flat.segment<3>(6),
                                      flat.segment<3>(9)};
        double f = 0;
        Eigen::Matrix<double, 3, 4> g;
        CHECK(SelfContactFadeVariable(pair, p, &f, &g));
        return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(g.data(), 12));
      };
      const Eigen::Map<const Eigen::VectorXd> flat(state.data(), 12);
      EXPECT_LT(testing::RelativeError(Eigen::Map<const Eigen::VectorXd>(gradient.data(), 12),
                                       testing::CentralDifferenceGradient(value_at, flat, 1e-6)),
                1e-7)
          << (edges ? "edge-edge" : "point-triangle") << "\n" << state;
      Eigen::Matrix<double, 12, 12> hessian;
      ASSERT_TRUE(SelfContactFadeVariableHessian(pair, points, &hessian));
      EXPECT_TRUE(testing::SymmetricHessianMatchesGradient(hessian, gradient_at, flat, 1e-6, 1e-6))
          << (edges ? "edge-edge" : "point-triangle") << "\n" << state;
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
