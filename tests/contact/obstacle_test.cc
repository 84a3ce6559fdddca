// Obstacle::SignedDistance (contact/obstacle.h): the signed distance to a closed surface and
// its gradient, on a rotated box near its faces, edges and corners.

#include "contact/obstacle.h"

#include <algorithm>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "contact/obstacle_penalty.h"
#include "mesh/surface_mesh.h"
#include "testing/contact_scenes.h"
#include "testing/element_states.h"
#include "testing/finite_difference.h"
#include "testing/test_surfaces.h"

namespace aqs {
namespace {

// A probe in the box's own frame (the box [0, 2] x [0, 1] x [0, 1]) with its closed-form
// signed distance and gradient there. Every probe lies at least 0.02 from the boundaries of
// its closest feature's region (and, inside, from the bisector of two faces), so the
// differencing steps stay where the distance is smooth.
struct Probe {
  std::string name;
  Eigen::Vector3d local;
  double distance;
  Eigen::Vector3d gradient;  // local frame
};

std::vector<Probe> BoxProbes() {
  return {
      {"outside near the face z = 1", Eigen::Vector3d(0.7, 0.3, 1.05), 0.05,
       Eigen::Vector3d(0, 0, 1)},
      // Closest point (0.8, 1, 1) on the edge y = z = 1.
      {"outside near the edge y = z = 1", Eigen::Vector3d(0.8, 1.03, 1.04), 0.05,
       Eigen::Vector3d(0, 0.6, 0.8)},
      // Closest point: the corner (2, 1, 1).
      {"outside near the corner (2, 1, 1)", Eigen::Vector3d(2.02, 1.03, 1.06), 0.07,
       Eigen::Vector3d(2, 3, 6) / 7},
      {"inside near the face z = 1", Eigen::Vector3d(0.8, 0.4, 0.95), -0.05,
       Eigen::Vector3d(0, 0, 1)},
      // 0.03 from the face y = 1, 0.08 from the face z = 1: the closest point is on y = 1.
      {"inside near the edge y = z = 1", Eigen::Vector3d(0.8, 0.97, 0.92), -0.03,
       Eigen::Vector3d(0, 1, 0)},
  };
}

// Trials 3 to 5 have every triangle turned inward (a file of the opposite winding, which
// is as closed and consistent): inside is still inside (its winding number is -1 there),
// and the gradient still points out.
TEST(ObstacleTest, SignedDistanceGradientOnARotatedBox) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 6; ++trial) {
    const Eigen::Matrix3d rotation = testing::RandomRotation(&rng);
    const Eigen::Vector3d shift(0.3 * trial, -0.2, 0.5);
    Eigen::Matrix3Xd v;
    Eigen::Matrix3Xi t;
    testing::BoxSurface(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 1, 1), &v, &t);
    if (trial >= 3) t.row(1).swap(t.row(2));
    v = (rotation * v).colwise() + shift;
    const Obstacle box("box", v, t);
    {
      // On the face z = 1: distance 0, the outward normal.
      Eigen::Vector3d gradient;
      const double d = box.SignedDistance(rotation * Eigen::Vector3d(0.7, 0.3, 1.0) + shift,
                                          &gradient);
      EXPECT_NEAR(d, 0.0, 1e-12);
      EXPECT_LT((gradient - rotation.col(2)).norm(), 1e-9) << gradient.transpose();
    }
    for (const Probe& probe : BoxProbes()) {
      SCOPED_TRACE("trial " + std::to_string(trial) + ": " + probe.name);
      const Eigen::Vector3d p = rotation * probe.local + shift;
      Eigen::Vector3d gradient;
      const double d = box.SignedDistance(p, &gradient);
      EXPECT_NEAR(d, probe.distance, 1e-12);
      EXPECT_EQ(d > 0, probe.distance > 0) << "positive outside, negative inside";
      EXPECT_NEAR(gradient.norm(), 1.0, 1e-12);
      EXPECT_LT((gradient - rotation * probe.gradient).norm(), 1e-12)
          << "gradient " << gradient.transpose() << ", expected "
          << (rotation * probe.gradient).transpose();
      auto distance = [&box](const Eigen::VectorXd& q) {
        Eigen::Vector3d unused;
        return box.SignedDistance(q, &unused);
      };
      const Eigen::VectorXd differenced = testing::CentralDifferenceGradient(distance, p, 1e-6);
      const double error = testing::RelativeError(gradient, differenced);
      // Measured: at most 2.4e-10 (round-off: distances of ~1e-2 at coordinates of ~2).
      EXPECT_LT(error, 3e-8) << "differenced " << differenced.transpose();
    }
  }
}

// FeatureDistanceHessian against central differences of each feature's direction (the
// distance's gradient), at random points about a rotated box and a notched prism (a
// concave crease), with a reach that takes in every feature so that the list's order does
// not change between the differenced points. Closest points at corners (dimension 0),
// inside segments (1) and inside triangles (2) all occur.
TEST(ObstacleTest, FeatureDistanceHessianMatchesDifferencesOfItsDirection) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int checked[3] = {0, 0, 0};
  for (int shape = 0; shape < 2; ++shape) {
    Eigen::Matrix3Xd v;
    Eigen::Matrix3Xi t;
    if (shape == 0) {
      testing::BoxSurface(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 1, 1), &v, &t);
    } else {
      testing::NotchedPrismSurface(0.6, &v, &t);
    }
    const Eigen::Matrix3d rotation = testing::RandomRotation(&rng);
    const Obstacle obstacle("shape", (rotation * v).colwise() + Eigen::Vector3d(0.2, -0.1, 0.4),
                            t);
    const double reach = 100.0;
    for (int i = 0; i < 30; ++i) {
      const Eigen::Vector3d p = rotation * Eigen::Vector3d(1.5 * uniform(rng), 1.5 * uniform(rng),
                                                           1.5 * uniform(rng)) +
                                Eigen::Vector3d(0.2, -0.1, 0.4);
      std::vector<FeatureDistance> features;
      obstacle.FeaturesWithin(p, reach, &features);
      for (size_t f = 0; f < features.size(); ++f) {
        if (features[f].distance < 1e-2) continue;  // too near its kink for the step
        SCOPED_TRACE("shape " + std::to_string(shape) + ", point " + std::to_string(i) +
                     ", feature " + std::to_string(f) + " of dimension " +
                     std::to_string(features[f].closest_dimension));
        auto direction = [&](const Eigen::VectorXd& q) -> Eigen::VectorXd {
          std::vector<FeatureDistance> at_q;
          obstacle.FeaturesWithin(q, reach, &at_q);
          EXPECT_EQ(at_q.size(), features.size());
          return at_q.size() == features.size() ? at_q[f].direction : Eigen::Vector3d::Zero();
        };
        const Eigen::Matrix3d hessian = FeatureDistanceHessian(features[f]);
        const Eigen::MatrixXd differenced = testing::CentralDifferenceJacobian(direction, p, 1e-6);
        // Measured: at most 1.1e-9 of the larger of 1 and the largest entry.
        EXPECT_LT(testing::RelativeError(hessian, differenced, 1.0), 1e-7)
            << "analytic\n" << hessian << "\ndifferenced\n" << differenced;
        ++checked[features[f].closest_dimension];
      }
    }
  }
  EXPECT_GT(checked[0], 100);
  EXPECT_GT(checked[1], 100);
  EXPECT_GT(checked[2], 20);
}

// A box without its top (a small hole is tolerated), either way oriented, far from the
// origin too: a point inside it is inside (its orientation came from the volume about
// the origin, which a hole makes depend on where the box is: 2 units up, it turned
// inside out).
TEST(ObstacleTest, AnOpenBoxFarFromTheOriginKeepsItsInside) {
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  testing::BoxSurface(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1), &v, &t);
  std::vector<int> kept;
  for (Eigen::Index c = 0; c < t.cols(); ++c) {
    if (v(2, t(0, c)) < 1 || v(2, t(1, c)) < 1 || v(2, t(2, c)) < 1) kept.push_back(int(c));
  }
  ASSERT_LT(kept.size(), static_cast<size_t>(t.cols()));
  const Eigen::Matrix3Xi open = t(Eigen::all, kept);
  for (const bool inward : {false, true}) {
    Eigen::Matrix3Xi faces = open;
    if (inward) faces.row(1).swap(faces.row(2));
    for (const double shift : {0.0, 3.0, 10.0, 100.0}) {
      SCOPED_TRACE(std::string(inward ? "inward" : "outward") + ", shifted " +
                   std::to_string(shift));
      const Eigen::Vector3d offset(0.2 * shift, -0.5 * shift, shift);
      const Obstacle box("open box", v.colwise() + offset, faces);
      Eigen::Vector3d gradient;
      EXPECT_NEAR(box.SignedDistance(Eigen::Vector3d(0.5, 0.5, 0.3) + offset, &gradient), -0.3,
                  1e-9);
      EXPECT_LT((gradient - Eigen::Vector3d(0, 0, -1)).norm(), 1e-9) << gradient.transpose();
    }
  }
}

// Two overlapping closed shells in one file (as the teeth of a dental model): split into
// one obstacle each, and a point in the overlap is pushed out of the union by the
// penalty (measured as one surface, it got the distance to the cap of one sphere buried
// in the other, and the penalty held it there; filtering the buried triangles left
// traps and jumps along the curve where the shells meet).
TEST(ObstacleTest, OverlappingShellsAreSplitAndAPointInTheOverlapIsPushedOut) {
  const SurfaceMesh left = testing::Icosphere(3, 1.0, Eigen::Vector3d(0, 0, 0));
  const SurfaceMesh right = testing::Icosphere(3, 1.0, Eigen::Vector3d(1.2, 0, 0));
  MovingObstacle both;
  both.name = "spheres";
  both.bone = 2;
  both.vertices.resize(3, left.num_vertices() + right.num_vertices());
  both.vertices << left.vertices, right.vertices;
  both.triangles.resize(3, left.triangles.cols() + right.triangles.cols());
  both.triangles << left.triangles, (right.triangles.array() + left.num_vertices()).matrix();
  const std::vector<MovingObstacle> shells = SplitIntoShells(both);
  ASSERT_EQ(shells.size(), 2u);
  EXPECT_EQ(shells[1].name, "spheres shell 2");
  EXPECT_EQ(shells[1].bone, 2);
  EXPECT_EQ(shells[0].vertices, left.vertices);
  EXPECT_EQ(shells[1].vertices, right.vertices);
  EXPECT_EQ(shells[1].triangles, right.triangles);
  EXPECT_EQ(SplitIntoShells(shells[0]).size(), 1u);
  std::vector<RigidTransform> bones(3);
  const std::unique_ptr<Obstacle> a = shells[0].Place(bones), b = shells[1].Place(bones);
  const std::vector<const Obstacle*> obstacles = {a.get(), b.get()};
  const double thickness = 0.05;
  // From points in the lens where the spheres overlap, normalized descent on the penalty
  // leaves the union (its nearest exit from (0.6, 0, 0.3) is up, through the circle where
  // the spheres meet) and stops within the thickness of it.
  for (const Eigen::Vector3d& start : {Eigen::Vector3d(0.6, 0, 0.3), Eigen::Vector3d(0.5, 0.2, 0),
                                       Eigen::Vector3d(0.7, -0.3, 0.4)}) {
    SCOPED_TRACE(start.transpose());
    Eigen::Vector3d p = start, gradient;
    for (int step = 0; step < 4000; ++step) {
      ObstaclePenalty(obstacles, thickness, p, &gradient, nullptr);
      if (gradient.norm() == 0.0) break;
      p -= 1e-3 * gradient.normalized();
    }
    Eigen::Vector3d g;
    const double d = std::min(a->SignedDistance(p, &g), b->SignedDistance(p, &g));
    EXPECT_GT(d, 0.0) << "ended at " << p.transpose();
    EXPECT_LT(d, thickness + 2e-3) << "ended at " << p.transpose();
  }
}

TEST(ObstacleTest, BeyondMaxDistanceOutsideIsTheCapWithAZeroGradient) {
  std::mt19937 rng(8);
  const Eigen::Matrix3d rotation = testing::RandomRotation(&rng);
  Eigen::Matrix3Xd v;
  Eigen::Matrix3Xi t;
  testing::BoxSurface(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 1, 1), &v, &t);
  const Obstacle box("box", rotation * v, t);
  // 0.5 above the face z = 1.
  const Eigen::Vector3d p = rotation * Eigen::Vector3d(1.2, 0.4, 1.5);
  Eigen::Vector3d gradient;
  EXPECT_EQ(box.SignedDistance(p, &gradient, 0.3), 0.3);
  EXPECT_EQ(gradient, Eigen::Vector3d::Zero());
  // Within the cap: the full answer.
  EXPECT_NEAR(box.SignedDistance(p, &gradient, 0.6), 0.5, 1e-12);
  EXPECT_LT((gradient - rotation.col(2)).norm(), 1e-12);
  // Inside, deeper than the cap: never capped (a deep penetration is one), the whole
  // depth and the outward direction. 0.45 below the face z = 1, 0.5 from the others.
  const Eigen::Vector3d deep = rotation * Eigen::Vector3d(1.2, 0.5, 0.55);
  EXPECT_NEAR(box.SignedDistance(deep, &gradient, 0.3), -0.45, 1e-12);
  EXPECT_LT((gradient - rotation.col(2)).norm(), 1e-12);
  EXPECT_NEAR(box.SignedDistance(deep, &gradient), -0.45, 1e-12);
}

}  // namespace
}  // namespace aqs
