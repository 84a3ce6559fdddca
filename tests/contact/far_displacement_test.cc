// MaxFarDisplacement (contact/far_displacement.h) against every pair of points.

#include "contact/far_displacement.h"

#include <algorithm>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace aqs {
namespace {

double BruteForce(const Eigen::Matrix3Xd& surface, const Eigen::VectorXd& moved,
                  const std::vector<char>& touched, double far_distance) {
  double largest = 0.0;
  for (Eigen::Index i = 0; i < surface.cols(); ++i) {
    double nearest = std::numeric_limits<double>::infinity();
    for (Eigen::Index c = 0; c < surface.cols(); ++c) {
      if (touched[c]) nearest = std::min(nearest, (surface.col(i) - surface.col(c)).norm());
    }
    if (nearest > far_distance) largest = std::max(largest, moved[i]);
  }
  return largest;
}

TEST(FarDisplacementTest, MatchesEveryPairOfPoints) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 300;
    Eigen::Matrix3Xd surface(3, n);
    Eigen::VectorXd moved(n);
    std::vector<char> touched(n, 0);
    for (int i = 0; i < n; ++i) {
      surface.col(i) << 4 * uniform(rng), 2 * uniform(rng), uniform(rng);
      moved[i] = uniform(rng);
      touched[i] = uniform(rng) < (trial % 4) * 0.02;  // none in a quarter of the trials
    }
    const double far = 0.2 + 0.1 * trial;
    const double expected = BruteForce(surface, moved, touched, far);
    EXPECT_EQ(MaxFarDisplacement(surface, moved, touched, far), expected) << "trial " << trial;
    if (trial % 4 == 0) {
      EXPECT_EQ(expected, moved.maxCoeff()) << "nothing touched: all far";
    }
  }
  // A point exactly the far distance from a touched one is not far.
  Eigen::Matrix3Xd two(3, 2);
  two << 0, 0.5, 0, 0, 0, 0;
  EXPECT_EQ(MaxFarDisplacement(two, Eigen::Vector2d(1.0, 2.0), {1, 0}, 0.5), 0.0);
  EXPECT_EQ(MaxFarDisplacement(two, Eigen::Vector2d(1.0, 2.0), {1, 0}, 0.49), 2.0);
}

}  // namespace
}  // namespace aqs
