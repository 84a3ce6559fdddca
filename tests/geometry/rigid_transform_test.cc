#include "geometry/rigid_transform.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace aqs {
namespace {

Eigen::Matrix3d RandomRotation(std::mt19937* rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(*rng), normal(*rng), normal(*rng), normal(*rng));
  return q.normalized().toRotationMatrix();
}

Eigen::Matrix3Xd RandomPoints(int count, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-2, 2);
  Eigen::Matrix3Xd points(3, count);
  for (int i = 0; i < count; ++i) points.col(i) << uniform(*rng), uniform(*rng), uniform(*rng);
  return points;
}

void ExpectProperRotation(const Eigen::Matrix3d& r) {
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
}

TEST(RigidTransformTest, ApplyAndInverse) {
  std::mt19937 rng(1);
  RigidTransform transform;
  transform.rotation = RandomRotation(&rng);
  transform.translation << 1, -2, 3;
  const Eigen::Matrix3Xd points = RandomPoints(10, &rng);
  const Eigen::Matrix3Xd moved = transform.Apply(points);
  for (int i = 0; i < 10; ++i) {
    EXPECT_LT((moved.col(i) - transform.ApplyToPoint(points.col(i))).norm(), 1e-14);
  }
  EXPECT_LT((transform.Inverse().Apply(moved) - points).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_EQ(RigidTransform().Apply(points), points);
}

TEST(RigidTransformTest, RecoversRandomMotionsExactly) {
  std::mt19937 rng(2);
  for (int trial = 0; trial < 20; ++trial) {
    RigidTransform truth;
    truth.rotation = RandomRotation(&rng);
    truth.translation = 5 * RandomPoints(1, &rng).col(0);
    const Eigen::Matrix3Xd from = RandomPoints(30, &rng);
    const Eigen::Matrix3Xd to = truth.Apply(from);
    double rms = -1;
    const RigidTransform fit = FitRigidTransform(from, to, &rms);
    ExpectProperRotation(fit.rotation);
    EXPECT_LT((fit.rotation - truth.rotation).norm(), 1e-12);
    EXPECT_LT((fit.translation - truth.translation).norm(), 1e-12);
    EXPECT_LT(rms, 1e-12);
  }
}

TEST(RigidTransformTest, NoisyPointsGiveTheNoiseLevel) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 0.01);
  RigidTransform truth;
  truth.rotation = RandomRotation(&rng);
  truth.translation << 0.3, 0.1, -0.7;
  const Eigen::Matrix3Xd from = RandomPoints(2000, &rng);
  Eigen::Matrix3Xd to = truth.Apply(from);
  for (int i = 0; i < to.cols(); ++i)
    to.col(i) += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  double rms = 0;
  const RigidTransform fit = FitRigidTransform(from, to, &rms);
  ExpectProperRotation(fit.rotation);
  EXPECT_LT((fit.rotation - truth.rotation).norm(), 2e-3);
  EXPECT_LT((fit.translation - truth.translation).norm(), 2e-3);
  // 3 coordinates of standard deviation 0.01: rms about 0.0173, a bit less after fitting.
  EXPECT_NEAR(rms, 0.01 * std::sqrt(3.0), 1e-3);
  // The fit is at least as good as the truth.
  const double truth_rms = std::sqrt((truth.Apply(from) - to).colwise().squaredNorm().mean());
  EXPECT_LE(rms, truth_rms + 1e-15);
}

TEST(RigidTransformTest, ReflectionsAreNeverReturned) {
  std::mt19937 rng(4);
  const Eigen::Matrix3Xd from = RandomPoints(50, &rng);
  // A mirror image fits exactly with a reflection; the best rotation leaves a residual.
  Eigen::Matrix3d mirror = Eigen::Matrix3d::Identity();
  mirror(2, 2) = -1;
  const Eigen::Matrix3Xd to = RandomRotation(&rng) * mirror * from;
  double rms = 0;
  const RigidTransform fit = FitRigidTransform(from, to, &rms);
  ExpectProperRotation(fit.rotation);
  EXPECT_GT(rms, 0.1);
  // Planar points (z = 0) mirrored in z are the same points: a rotation fits exactly.
  Eigen::Matrix3Xd planar = from;
  planar.row(2).setZero();
  const RigidTransform planar_fit = FitRigidTransform(planar, mirror * planar, &rms);
  ExpectProperRotation(planar_fit.rotation);
  EXPECT_LT(rms, 1e-12);
}

TEST(RigidTransformTest, WeightsAndDegenerateSets) {
  std::mt19937 rng(5);
  RigidTransform truth;
  truth.rotation = RandomRotation(&rng);
  truth.translation << -1, 2, 0.5;
  const Eigen::Matrix3Xd from = RandomPoints(20, &rng);
  Eigen::Matrix3Xd to = truth.Apply(from);
  to.col(3) += Eigen::Vector3d(10, -5, 3);  // an outlier...
  Eigen::VectorXd weights = Eigen::VectorXd::Constant(20, 2.0);
  weights(3) = 0;  // ...that has no weight
  double rms = -1;
  const RigidTransform fit = FitRigidTransform(from, to, weights, &rms);
  EXPECT_LT((fit.rotation - truth.rotation).norm(), 1e-12);
  EXPECT_LT((fit.translation - truth.translation).norm(), 1e-12);
  EXPECT_LT(rms, 1e-12);
  double unweighted_rms = 0;
  FitRigidTransform(from, to, &unweighted_rms);
  EXPECT_GT(unweighted_rms, 0.1);

  // One point: a proper rotation and the translation that maps it.
  const RigidTransform single = FitRigidTransform(from.leftCols(1), to.leftCols(1), &rms);
  ExpectProperRotation(single.rotation);
  EXPECT_LT((single.ApplyToPoint(from.col(0)) - to.col(0)).norm(), 1e-12);
  EXPECT_LT(rms, 1e-12);
  // Collinear points: the line is mapped exactly.
  Eigen::Matrix3Xd line(3, 5);
  for (int i = 0; i < 5; ++i) line.col(i) = Eigen::Vector3d(1, 2, 3) * i;
  const RigidTransform line_fit = FitRigidTransform(line, truth.Apply(line), &rms);
  ExpectProperRotation(line_fit.rotation);
  EXPECT_LT(rms, 1e-12);
}

TEST(InterpolateRigidTransformTest, ScrewMotionAboutAPivot) {
  // A rotation by 0.6 rad about the axis (0, 0, 1) through the pivot (2, 1, 0), then 0.3
  // along the axis: halfway, points have turned 0.3 rad about the same pivot and moved
  // 0.15 along the axis, at the same distance from it.
  const Eigen::Vector3d pivot(2, 1, 0), axis(0, 0, 1);
  RigidTransform motion;
  motion.rotation = Eigen::AngleAxisd(0.6, axis).toRotationMatrix();
  motion.translation = pivot - motion.rotation * pivot + 0.3 * axis;
  const RigidTransform start = InterpolateRigidTransform(motion, 0.0);
  EXPECT_LT((start.rotation - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_LT(start.translation.norm(), 1e-12);
  const RigidTransform end = InterpolateRigidTransform(motion, 1.0);
  EXPECT_LT((end.rotation - motion.rotation).norm(), 1e-12);
  EXPECT_LT((end.translation - motion.translation).norm(), 1e-12);
  const RigidTransform half = InterpolateRigidTransform(motion, 0.5);
  const Eigen::Matrix3d half_rotation = Eigen::AngleAxisd(0.3, axis).toRotationMatrix();
  const Eigen::Vector3d p(3, -1, 2);
  const Eigen::Vector3d expected = half_rotation * (p - pivot) + pivot + 0.15 * axis;
  EXPECT_LT((half.ApplyToPoint(p) - expected).norm(), 1e-12);
  // A pure translation is scaled.
  RigidTransform shift;
  shift.translation << 1, -2, 4;
  const RigidTransform quarter = InterpolateRigidTransform(shift, 0.25);
  EXPECT_LT((quarter.translation - Eigen::Vector3d(0.25, -0.5, 1)).norm(), 1e-15);
  EXPECT_LT((quarter.rotation - Eigen::Matrix3d::Identity()).norm(), 1e-15);
}

}  // namespace
}  // namespace aqs
