#include "physics/rotation_variant_svd.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <gtest/gtest.h>

#include "testing/element_states.h"

namespace aqs {
namespace {

// The matrices a simulation meets, by family, each with a name for failure messages.
struct NamedMatrix {
  std::string name;
  Eigen::Matrix3d g;
};

Eigen::Matrix3d FromSingularValues(const Eigen::Vector3d& sigma, std::mt19937* rng) {
  return testing::RandomRotation(rng) * sigma.asDiagonal() * testing::RandomRotation(rng);
}

std::vector<NamedMatrix> TestMatrices() {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> exponent(-8.0, 0.0);
  std::vector<NamedMatrix> out;
  for (const auto& state : testing::DerivativeTestStates(20, 5)) {
    out.push_back({"state " + state.name, state.f * state.s});
  }
  for (int i = 0; i < 200; ++i) {
    const std::string n = std::to_string(i);
    Eigen::Matrix3d m;
    for (int k = 0; k < 9; ++k) m(k) = normal(rng);
    out.push_back({"gaussian " + n, m});
    out.push_back({"near rest " + n, Eigen::Matrix3d::Identity() + 1e-3 * m});
    out.push_back({"rotated near rest " + n,
                   testing::RandomRotation(&rng) * (Eigen::Matrix3d::Identity() + 1e-2 * m)});
    out.push_back({"scaled " + n, std::pow(10.0, 6.0 * exponent(rng) / 8.0 + 3.0) * m});
    // Repeated and nearly repeated singular values, both signs of det.
    const double d = std::pow(10.0, exponent(rng));
    out.push_back({"two equal " + n, FromSingularValues({1.0 + d, 1.0, 1.0}, &rng)});
    out.push_back({"triple " + n, FromSingularValues({1.0, 1.0, 1.0 + 1e-12 * d}, &rng)});
    out.push_back({"inverted " + n, FromSingularValues({2.0, 1.0, -0.5 * d}, &rng)});
    out.push_back({"inverted equal " + n, FromSingularValues({1.0, 1.0, -1.0}, &rng)});
    // Flattened and collapsed elements (the fallback's domain).
    out.push_back({"flat " + n, FromSingularValues({1.0, d, 1e-3 * d}, &rng)});
    out.push_back({"needle " + n, FromSingularValues({1.0, 1e-9, -1e-11}, &rng)});
    out.push_back({"rank one " + n, FromSingularValues({3.0, 0.0, 0.0}, &rng)});
  }
  out.push_back({"zero", Eigen::Matrix3d::Zero()});
  out.push_back({"identity", Eigen::Matrix3d::Identity()});
  out.push_back({"reflection", Eigen::Vector3d(1, 1, -1).asDiagonal()});
  out.push_back({"permutation", (Eigen::Matrix3d() << 0, 1, 0, 0, 0, 1, 1, 0, 0).finished()});
  out.push_back({"negative diagonal", Eigen::Vector3d(-3, -2, -1).asDiagonal()});
  return out;
}

TEST(RotationVariantSvdTest, IsAnAccurateRotationVariantSvd) {
  for (const NamedMatrix& m : TestMatrices()) {
    const RotationVariantSvd svd = ComputeRotationVariantSvd(m.g);
    const double scale = std::max(m.g.norm(), 1e-300);
    EXPECT_LT((svd.u * svd.sigma.asDiagonal() * svd.v.transpose() - m.g).norm(), 1e-14 * scale)
        << m.name;
    EXPECT_LT((svd.u.transpose() * svd.u - Eigen::Matrix3d::Identity()).norm(), 1e-14) << m.name;
    EXPECT_LT((svd.v.transpose() * svd.v - Eigen::Matrix3d::Identity()).norm(), 1e-14) << m.name;
    EXPECT_NEAR(svd.u.determinant(), 1.0, 1e-14) << m.name;
    EXPECT_NEAR(svd.v.determinant(), 1.0, 1e-14) << m.name;
    EXPECT_GE(svd.sigma[0], svd.sigma[1]) << m.name;
    EXPECT_GE(svd.sigma[1], std::abs(svd.sigma[2])) << m.name;
    EXPECT_GE(svd.sigma[1], 0.0) << m.name;
    // The singular values agree with Eigen's to a few epsilons of sigma_0, and the sign
    // of the last one is the sign of det G.
    const RotationVariantSvd reference = RotationVariantSvdReference(m.g);
    EXPECT_LT((svd.sigma - reference.sigma).cwiseAbs().maxCoeff(), 1e-14 * scale) << m.name;
    const double det = m.g.determinant();
    if (std::abs(det) > 1e-10 * std::pow(scale, 3)) {
      EXPECT_EQ(svd.sigma[2] < 0, det < 0) << m.name;
    }
    // The polar rotation is unique where sigma_1 + sigma_2 is clearly positive.
    if (svd.sigma[1] + svd.sigma[2] > 1e-6 * svd.sigma[0]) {
      const Eigen::Matrix3d r = svd.u * svd.v.transpose();
      const Eigen::Matrix3d r_reference = reference.u * reference.v.transpose();
      EXPECT_LT((r - r_reference).norm(),
                1e-13 * svd.sigma[0] / (svd.sigma[1] + svd.sigma[2]))
          << m.name;
    }
  }
}

// The fast path must serve every family but the flat and collapsed ones, or the speed
// is lost; and where it serves, it must agree with the checks above.
TEST(RotationVariantSvdTest, FastPathServesRegularStates) {
  int served = 0;
  int regular = 0;
  for (const NamedMatrix& m : TestMatrices()) {
    const bool flat = m.name.rfind("flat", 0) == 0 || m.name.rfind("needle", 0) == 0 ||
                      m.name.rfind("rank one", 0) == 0 || m.name.rfind("state", 0) == 0 ||
                      m.name == "zero";
    if (flat) continue;
    ++regular;
    RotationVariantSvd svd;
    if (JacobiQrSvd(m.g, &svd)) ++served;
  }
  EXPECT_EQ(served, regular);
}

// Where the fast path refuses (flat and collapsed states), the fallback's rotation
// U V^T is checked by what defines it, not against the reference it is built from: it
// maximizes tr(R^T G) over rotations, random ones and ones turned by 1e-3 and 1e-2.
TEST(RotationVariantSvdTest, FallbackRotationMaximizesTheTrace) {
  std::mt19937 rng(13);
  std::normal_distribution<double> normal(0.0, 1.0);
  int fallbacks = 0;
  for (const NamedMatrix& m : TestMatrices()) {
    RotationVariantSvd fast;
    if (JacobiQrSvd(m.g, &fast)) continue;
    ++fallbacks;
    const RotationVariantSvd svd = ComputeRotationVariantSvd(m.g);
    const Eigen::Matrix3d r = svd.u * svd.v.transpose();
    const double best = (r.transpose() * m.g).trace();
    const double slack = 1e-13 * std::max(m.g.norm(), 1e-300);
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Matrix3d other = testing::RandomRotation(&rng) * r;
      EXPECT_LE((other.transpose() * m.g).trace(), best + slack) << m.name;
    }
    for (const double angle : {1e-3, 1e-2}) {
      for (int trial = 0; trial < 10; ++trial) {
        const Eigen::Vector3d axis =
            Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
        const Eigen::Matrix3d other = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * r;
        EXPECT_LE((other.transpose() * m.g).trace(), best + slack)
            << m.name << " angle " << angle;
      }
    }
  }
  EXPECT_GT(fallbacks, 100) << "the flat and collapsed families must reach the fallback";
}

TEST(RotationVariantSvdTest, NonFiniteInputGivesNan) {
  Eigen::Matrix3d g = Eigen::Matrix3d::Identity();
  g(1, 2) = std::numeric_limits<double>::quiet_NaN();
  const RotationVariantSvd svd = ComputeRotationVariantSvd(g);
  EXPECT_TRUE(svd.sigma.array().isNaN().all());
  EXPECT_TRUE(svd.u.array().isNaN().all());
  g(1, 2) = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(ComputeRotationVariantSvd(g).v.array().isNaN().all());
}

}  // namespace
}  // namespace aqs
