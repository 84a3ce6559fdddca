// ObstaclePenalty (contact/obstacle_penalty.h): the per-point contact penalty as a sum over
// the obstacles' features. It is the nearest distance's penalty where the features' closest
// points coincide, C1 at a concave crease, continuous through the surface, and its
// gradient matches central differences at random, rotated and near-degenerate points.

#include "contact/obstacle_penalty.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "testing/contact_scenes.h"
#include "testing/element_states.h"
#include "testing/finite_difference.h"

namespace aqs {
namespace {

double Phi(double thickness, double d) {
  const double gap = std::max(0.0, thickness - d);
  return 0.5 * gap * gap;
}

double Penalty(const Obstacle& obstacle, double thickness, const Eigen::Vector3d& p,
               Eigen::Vector3d* gradient = nullptr, Eigen::Matrix3d* hessian = nullptr) {
  Eigen::Vector3d g;
  const double value = ObstaclePenalty({&obstacle}, thickness, p, &g, hessian);
  if (gradient != nullptr) *gradient = g;
  return value;
}

// The penalty's gradient at p against fourth-order central differences (step h).
double GradientError(const std::vector<const Obstacle*>& obstacles, double thickness,
                     const Eigen::Vector3d& p, double h) {
  Eigen::Vector3d gradient;
  ObstaclePenalty(obstacles, thickness, p, &gradient, nullptr);
  auto penalty = [&](const Eigen::VectorXd& q) {
    Eigen::Vector3d unused;
    return ObstaclePenalty(obstacles, thickness, q, &unused, nullptr);
  };
  return testing::RelativeError(gradient, testing::CentralDifferenceGradient(penalty, p, h),
                                1e-3);
}

// The axis-aligned box [lo, hi] as an obstacle.
Obstacle BoxObstacle(const std::string& name, const Eigen::Vector3d& lo,
                     const Eigen::Vector3d& hi) {
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  testing::BoxSurface(lo, hi, &v, &t);
  return Obstacle(name, v, t);
}

// A rotated, shifted box [0, 2] x [0, 1] x [0, 1] (12 triangles: each face split by a
// diagonal, which its sum must cancel).
Obstacle RotatedBox(std::mt19937* rng, Eigen::Matrix3d* rotation, Eigen::Vector3d* shift) {
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  testing::BoxSurface(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 1, 1), &v, &t);
  *rotation = testing::RandomRotation(rng);
  *shift = Eigen::Vector3d(0.3, -0.2, 0.7);
  return Obstacle("box", (*rotation * v).colwise() + *shift, t);
}

TEST(ObstaclePenaltyTest, IsTheNearestDistancesPenaltyWhereClosestPointsCoincide) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Eigen::Matrix3d rotation;
  Eigen::Vector3d shift;
  const Obstacle box = RotatedBox(&rng, &rotation, &shift);
  const double thickness = 0.1;
  // Outside a convex box every feature's closest point lies on the nearest one's closure,
  // so the sum reduces to phi(d) near faces, edges and corners alike.
  int outside = 0, inside = 0;
  for (int i = 0; i < 4000; ++i) {
    const Eigen::Vector3d local(-0.12 + 2.24 * uniform(rng), -0.12 + 1.24 * uniform(rng),
                                -0.12 + 1.24 * uniform(rng));
    const Eigen::Vector3d p = rotation * local + shift;
    Eigen::Vector3d g;
    const double s = box.SignedDistance(p, &g);
    if (!(s < thickness)) continue;
    // Inside, only where one face is within reach (no convex edge nearer than t).
    const Eigen::Vector3d to_hi = Eigen::Vector3d(2, 1, 1) - local;
    const Eigen::Vector3d gaps = local.cwiseMin(to_hi);
    std::vector<double> sorted(gaps.data(), gaps.data() + 3);
    std::sort(sorted.begin(), sorted.end());
    if (s < 0 && sorted[1] < thickness) continue;
    ++(s < 0 ? inside : outside);
    Eigen::Vector3d gradient;
    Eigen::Matrix3d hessian;
    const double penalty = Penalty(box, thickness, p, &gradient, &hessian);
    ASSERT_NEAR(penalty, Phi(thickness, s), 1e-13) << "local " << local.transpose();
    ASSERT_LT((gradient + (thickness - s) * g).norm(), 1e-12) << "local " << local.transpose();
    // About an edge or corner the curvature, -(t - d) / d across it, is removed by the
    // projection up to round-off of its size.
    ASSERT_LT((hessian - g * g.transpose()).norm(), 1e-13 * (1.0 + thickness / std::abs(s)))
        << "local " << local.transpose();
  }
  EXPECT_GT(outside, 300);
  EXPECT_GT(inside, 50);
}

// The notched prism (testing::NotchedPrismSurface) rotated: its crease along local z.
struct Notch {
  Obstacle obstacle;
  Eigen::Matrix3d rotation;
  Eigen::Vector3d shift;
  double depth;
  Eigen::Vector3d World(const Eigen::Vector3d& local) const { return rotation * local + shift; }
};

Notch MakeNotch(std::mt19937* rng, double depth) {
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  testing::NotchedPrismSurface(depth, &v, &t);
  const Eigen::Matrix3d rotation = testing::RandomRotation(rng);
  const Eigen::Vector3d shift(-0.4, 0.9, 0.2);
  return {Obstacle("notch", (rotation * v).colwise() + shift, t), rotation, shift, depth};
}

TEST(ObstaclePenaltyTest, IsC1AcrossAConcaveCreaseWhereTheNearestPenaltyKinks) {
  std::mt19937 rng(11);
  const Notch notch = MakeNotch(&rng, 0.2);  // faces 11.3 degrees off the horizontal
  const double thickness = 0.05;
  // Across the bisector x = 0, 0.03 above the crease: the nearest face changes there.
  for (double eps : {1e-4, 1e-7}) {
    SCOPED_TRACE(eps);
    const Eigen::Vector3d left = notch.World(Eigen::Vector3d(-eps, -0.2 + 0.03, 0.1));
    const Eigen::Vector3d right = notch.World(Eigen::Vector3d(eps, -0.2 + 0.03, 0.1));
    Eigen::Vector3d g_left, g_right, n_left, n_right;
    Penalty(notch.obstacle, thickness, left, &g_left);
    Penalty(notch.obstacle, thickness, right, &g_right);
    const double d_left = notch.obstacle.SignedDistance(left, &n_left);
    const double d_right = notch.obstacle.SignedDistance(right, &n_right);
    // The nearest penalty's gradient, -(t - d) n, jumps by (t - d) |n_left - n_right|
    // (measured 0.0039 at 0.03 above the crease).
    const double nearest_jump =
        ((thickness - d_left) * n_left - (thickness - d_right) * n_right).norm();
    EXPECT_GT(nearest_jump, 3e-3);
    // The sum's changes by O(eps) (its Hessian there is about 1).
    EXPECT_LT((g_left - g_right).norm(), 10 * eps);
  }
}

TEST(ObstaclePenaltyTest, IsContinuousThroughTheSurface) {
  std::mt19937 rng(13);
  const double thickness = 0.05;
  // At a crease of 157 degrees (depth 0.2) a point of one face sees the other's interior
  // nowhere, and the sum is phi(0) on the surface; at 67 degrees (depth 1.5) it does
  // within reach of the crease, where the sum exceeds phi(0) outside and the inside's
  // depth term must meet it.
  for (double depth : {0.2, 1.5}) {
    const Notch notch = MakeNotch(&rng, depth);
    const double slope = std::atan(depth);
    for (double along : {0.002, 0.01, 0.03, 0.3}) {
      SCOPED_TRACE("depth " + std::to_string(depth) + ", " + std::to_string(along) +
                   " from the crease");
      // On the right face (from (0, -depth) up to (1, 0)).
      const Eigen::Vector3d on = notch.World(
          Eigen::Vector3d(along * std::cos(slope), -depth + along * std::sin(slope), 0.3));
      const Eigen::Vector3d normal =
          notch.rotation * Eigen::Vector3d(-std::sin(slope), std::cos(slope), 0);
      const double step = 1e-9;
      const double out = Penalty(notch.obstacle, thickness, on + step * normal);
      const double in = Penalty(notch.obstacle, thickness, on - step * normal);
      EXPECT_NEAR(out, in, 4 * thickness * step);  // the gradient is at most about 2 t
      if (depth > 1.0 && along < thickness) {
        EXPECT_GT(out, Phi(thickness, 0.0) + 1e-6);
      } else {
        EXPECT_NEAR(out, Phi(thickness, 0.0), 2 * thickness * step);
      }
    }
  }
}

TEST(ObstaclePenaltyTest, GradientMatchesDifferencesNearACreaseItsEndsAndInside) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const double thickness = 0.05;
  for (int trial = 0; trial < 3; ++trial) {
    const Notch notch = MakeNotch(&rng, trial == 0 ? 0.2 : (trial == 1 ? 1.5 : 0.01));
    SCOPED_TRACE("depth " + std::to_string(notch.depth));
    // (name, local position, difference step, tolerance): 1e-6 above the crease the
    // edge's curvature (t - d) / d is 5e4, so the step must be far smaller than the
    // distance (and no smaller than 1e-8: the distances' round-off); there the region
    // where both faces' interiors are nearest is 2e-8 wide at the flattest crease, and
    // the differences straddle its C1-only boundaries (measured 1.2e-5).
    std::vector<std::tuple<std::string, Eigen::Vector3d, double, double>> points = {
        {"on the bisector, 1e-6 above the crease", Eigen::Vector3d(0, -notch.depth + 1e-6, 0.2),
         1e-8, 5e-5},
        {"near the crease's end (a cap's corner)",
         Eigen::Vector3d(0.01, -notch.depth + 0.02, 1.02), 1e-7, 1e-6},
        {"inside below the crease", Eigen::Vector3d(0.003, -notch.depth - 0.01, -0.4), 1e-7,
         1e-6},
        {"inside near a cap and a face", Eigen::Vector3d(0.5, -0.03, 0.985), 1e-7, 1e-6},
    };
    for (int i = 0; i < 40; ++i) {  // random points in the band about the crease
      points.push_back({"random " + std::to_string(i),
                        Eigen::Vector3d(0.06 * uniform(rng),
                                        -notch.depth + 0.02 + 0.03 * uniform(rng),
                                        0.9 * uniform(rng)),
                        1e-7, 1e-6});
    }
    int checked = 0;
    for (const auto& [name, local, step, tolerance] : points) {
      SCOPED_TRACE(name);
      const Eigen::Vector3d p = notch.World(local);
      Eigen::Vector3d gradient;
      Eigen::Matrix3d hessian;
      const double penalty = Penalty(notch.obstacle, thickness, p, &gradient, &hessian);
      if (penalty == 0.0) continue;  // out of reach
      ++checked;
      EXPECT_GT(penalty, 0.0);
      EXPECT_LT(GradientError({&notch.obstacle}, thickness, p, step), tolerance);
      // Symmetric and positive semi-definite up to round-off of its size (1e-6 above the
      // crease the edge's curvature is 5e4).
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(hessian);
      EXPECT_GE(eigen.eigenvalues().minCoeff(), -1e-14 * (1.0 + hessian.norm()));
      EXPECT_LT((hessian - hessian.transpose()).norm(), 1e-14 * (1.0 + hessian.norm()));
    }
    // Most of the band is within reach: the checks above ran, not skipped.
    EXPECT_GE(checked, 40);  // measured: 43, 43 and 44 of the 44
  }
}

// A symmetric 3 x 3 matrix with its negative eigenvalues set to 0.
Eigen::Matrix3d ProjectedPsd(const Eigen::Matrix3d& symmetric) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(symmetric);
  return eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() *
         eigen.eigenvectors().transpose();
}

// Outside the obstacle the Hessian is the exact second derivative with its negative
// eigenvalues set to 0: the projected, symmetrized central differences of the gradient,
// at random points in the band about the notch's crease (where the negative-weight edge
// adds positive curvature that the Gauss-Newton sum lacks) and near the faces. Points
// within 1e-3 of the bisector, where the nearest face changes and the penalty is C1 only,
// are skipped.
TEST(ObstaclePenaltyTest, HessianIsTheProjectedSecondDerivativeOutside) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const double thickness = 0.05;
  int checked = 0, curved = 0;
  for (double depth : {0.2, 1.5}) {
    const Notch notch = MakeNotch(&rng, depth);
    for (int i = 0; i < 150; ++i) {
      const Eigen::Vector3d local(0.1 * uniform(rng), -depth + 0.03 + 0.03 * uniform(rng),
                                  0.8 * uniform(rng));
      if (std::abs(local.x()) < 1e-3) continue;
      const Eigen::Vector3d p = notch.World(local);
      Eigen::Vector3d unused;
      if (!(notch.obstacle.SignedDistance(p, &unused) > 1e-3)) continue;
      SCOPED_TRACE("depth " + std::to_string(depth) + ", point " + std::to_string(i));
      Eigen::Vector3d gradient;
      Eigen::Matrix3d hessian;
      if (Penalty(notch.obstacle, thickness, p, &gradient, &hessian) == 0.0) continue;
      auto gradient_at = [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
        Eigen::Vector3d g;
        Penalty(notch.obstacle, thickness, q, &g);
        return g;
      };
      const Eigen::Matrix3d differenced = testing::CentralDifferenceJacobian(gradient_at, p, 1e-7);
      const Eigen::Matrix3d projected =
          ProjectedPsd(0.5 * (differenced + differenced.transpose()));
      // Measured: at most 2.0e-8 of the larger of 1 and the largest entry.
      EXPECT_LT(testing::RelativeError(hessian, projected, 1.0), 1e-6)
          << "analytic\n" << hessian << "\nprojected differences\n" << projected;
      ++checked;
      // Where the edge's curvature counts, the Hessian differs from the projected
      // Gauss-Newton sum, sum_f w_f n_f n_f^T (the stiffness before 2026-12-07).
      std::vector<FeatureDistance> features;
      notch.obstacle.FeaturesWithin(p, thickness, &features);
      Eigen::Matrix3d gauss_newton = Eigen::Matrix3d::Zero();
      for (const FeatureDistance& f : features) {
        gauss_newton += f.weight * f.direction * f.direction.transpose();
      }
      if ((hessian - ProjectedPsd(gauss_newton)).norm() > 1e-3) ++curved;
    }
  }
  EXPECT_GT(checked, 60);
  EXPECT_GT(curved, 10);
}

// Toward an edge the features' curvature (t - d) / d grows without bound: about a convex
// edge of a rotated box its terms cancel but for round-off of order 1e-16 / d^2 (measured
// 2.2e7 at 1e-12 before the floor), in a concave crease it is t / r. The Hessian bounds it
// by taking d no less than t / 100, so its norm stays within 1 + 2 * 100 (the weights
// are +-1), and about a convex edge it is n n^T to 1e-2.
TEST(ObstaclePenaltyTest, HessianStaysBoundedTowardAnEdge) {
  std::mt19937 rng(31);
  const double thickness = 0.05;
  Eigen::Matrix3d rotation;
  Eigen::Vector3d shift;
  const Obstacle box = RotatedBox(&rng, &rotation, &shift);
  const Notch notch = MakeNotch(&rng, 0.2);
  for (double distance : {1e-4, 1e-6, 1e-8, 1e-10, 1e-11, 1e-12, 0.0}) {
    SCOPED_TRACE(distance);
    // Off the convex edge y = z = 1 of the box, along its outward bisector.
    const Eigen::Vector3d off_edge =
        rotation * (Eigen::Vector3d(0.7, 1, 1) +
                    distance * Eigen::Vector3d(0, 1, 1) / std::sqrt(2.0)) + shift;
    Eigen::Vector3d gradient;
    Eigen::Matrix3d hessian;
    Penalty(box, thickness, off_edge, &gradient, &hessian);
    EXPECT_TRUE(hessian.allFinite());
    if (distance > 0.0) {
      const Eigen::Vector3d n = rotation * Eigen::Vector3d(0, 1, 1) / std::sqrt(2.0);
      EXPECT_LT((hessian - n * n.transpose()).norm(), 1e-2) << hessian;
    }
    EXPECT_LT(hessian.norm(), 3.0) << hessian;
    // Above the notch's crease.
    const Eigen::Vector3d above = notch.World(Eigen::Vector3d(0, -notch.depth + distance, 0.3));
    Penalty(notch.obstacle, thickness, above, &gradient, &hessian);
    EXPECT_TRUE(hessian.allFinite());
    EXPECT_LT(hessian.norm(), 1.0 + 2.0 * 100.0) << hessian;
  }
}

// On the surface the penalty's gradient is -t n, as on either side of it: at the centre of
// a face, where the face's two triangles and their diagonal meet (the triangles counted
// their normals, the diagonal nothing: -2 t n), and on a convex edge (two faces' normals:
// t sqrt(2) long). Within 1e-12 of the surface the features whose closest point is the
// point take the obstacle's normal, inward when the point counts as inside.
TEST(ObstaclePenaltyTest, OnTheSurfaceTheGradientIsTheNormalsOnce) {
  std::mt19937 rng(37);
  Eigen::Matrix3d rotation;
  Eigen::Vector3d shift;
  const Obstacle box = RotatedBox(&rng, &rotation, &shift);
  const double thickness = 0.05;
  const Eigen::Vector3d n = rotation.col(2);  // the face z = 1
  for (double offset : {-1e-10, -1e-13, 0.0, 1e-13, 1e-10}) {
    SCOPED_TRACE(offset);
    const Eigen::Vector3d centre = rotation * Eigen::Vector3d(1, 0.5, 1 + offset) + shift;
    Eigen::Vector3d gradient;
    Eigen::Matrix3d hessian;
    const double penalty = Penalty(box, thickness, centre, &gradient, &hessian);
    EXPECT_NEAR(penalty, Phi(thickness, 0.0), 1e-11);
    if (std::abs(offset) < 1e-12) {
      EXPECT_LT((gradient + thickness * n).norm(), 1e-12) << gradient.transpose();
      EXPECT_LT((hessian - n * n.transpose()).norm(), 1e-12) << hessian;
    } else {
      // 1e-10 off, the closest points of the two triangles and the diagonal agree to
      // round-off (1e-16 / 1e-10 in their directions: measured 1.5e-7 in the gradient).
      // Exactly above the diagonal both triangles' closest points lie on it, so one
      // segment's curvature is counted where the sum is flat on either side: the
      // Hessian is only bounded there (1 + 100, a set of no volume).
      EXPECT_LT((gradient + thickness * n).norm(), 1e-5 * thickness) << gradient.transpose();
      EXPECT_LT(hessian.norm(), 1.0 + 2.0 * 100.0) << hessian;
    }
  }
  const Eigen::Vector3d on_edge = rotation * Eigen::Vector3d(0.7, 1, 1) + shift;
  Eigen::Vector3d gradient;
  Penalty(box, thickness, on_edge, &gradient);
  EXPECT_NEAR(gradient.norm(), thickness, 1e-9) << gradient.transpose();
}

TEST(ObstaclePenaltyTest, PenaltiesOfSeveralObstaclesAdd) {
  // Two boxes 0.06 apart along x and a point between them: 0.02 from one, 0.04 from the
  // other (the nearest distance alone saw only the first, and kinked midway).
  const Obstacle first = BoxObstacle("first", Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1));
  const Obstacle second =
      BoxObstacle("second", Eigen::Vector3d(1.06, 0, 0), Eigen::Vector3d(2, 1, 1));
  const double thickness = 0.05;
  const Eigen::Vector3d p(1.02, 0.4, 0.6);
  Eigen::Vector3d gradient;
  Eigen::Matrix3d hessian;
  const double penalty = ObstaclePenalty({&first, &second}, thickness, p, &gradient, &hessian);
  EXPECT_NEAR(penalty, Phi(thickness, 0.02) + Phi(thickness, 0.04), 1e-14);
  EXPECT_LT((gradient - Eigen::Vector3d(-(0.03 - 0.01), 0, 0)).norm(), 1e-13);
  EXPECT_LT((hessian - 2 * Eigen::Vector3d::UnitX() * Eigen::Vector3d::UnitX().transpose())
                .norm(),
            1e-13);
  EXPECT_LT(GradientError({&first, &second}, thickness, p, 1e-6), 1e-8);
  // Deep inside one obstacle, out of reach of any feature: the depth's own penalty.
  Eigen::Vector3d g;
  EXPECT_NEAR(ObstaclePenalty({&first, &second}, thickness, Eigen::Vector3d(0.5, 0.5, 0.5), &g,
                              &hessian),
              Phi(thickness, -0.5), 1e-14);
  EXPECT_EQ(ObstaclePenalty({}, thickness, p, &g, &hessian), 0.0);
  EXPECT_TRUE(g.isZero());
}

// A point inside two overlapping obstacles is pushed out of each: with the depth of the
// deepest alone, the nearer face of the other one (whose distance the feature sum sees
// unsigned) drew it deeper into that one.
TEST(ObstaclePenaltyTest, APointInsideTwoObstaclesIsPushedOutOfEach) {
  const Obstacle a = BoxObstacle("a", Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 1, 1));
  const Obstacle b = BoxObstacle("b", Eigen::Vector3d(1.5, 0, 0), Eigen::Vector3d(3, 1, 1));
  const double thickness = 0.05;
  // 0.04 below both tops, 0.03 inside b's face x = 1.5 (which lies inside a).
  const Eigen::Vector3d p(1.53, 0.5, 0.96);
  Eigen::Vector3d gradient;
  ObstaclePenalty({&a, &b}, thickness, p, &gradient, nullptr);
  EXPECT_LT(-gradient.x(), 0.0) << "out of b, not deeper in: " << gradient.transpose();
  EXPECT_GT(-gradient.z(), 0.0) << "up, out of both: " << gradient.transpose();
  EXPECT_LT(GradientError({&a, &b}, thickness, p, 1e-7), 1e-6);
}

}  // namespace
}  // namespace aqs
