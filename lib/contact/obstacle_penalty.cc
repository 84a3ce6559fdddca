#include "contact/obstacle_penalty.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

namespace aqs {

double NearestObstacleDistance(const std::vector<const Obstacle*>& obstacles,
                               const Eigen::Vector3d& p, Eigen::Vector3d* gradient) {
  double best = std::numeric_limits<double>::infinity();
  gradient->setZero();
  for (const Obstacle* obstacle : obstacles) {
    Eigen::Vector3d g;
    // The first obstacle in full (contact candidates are chosen by distances beyond the
    // thickness); the others only as far as the nearest so far, which is all that can win
    // (points inside are found at any depth).
    const double d = obstacle->SignedDistance(p, &g, std::min(best, 1e300));
    if (d < best) {
      best = d;
      *gradient = g;
    }
  }
  return best;
}

double ObstaclePenalty(const std::vector<const Obstacle*>& obstacles, double thickness,
                       const Eigen::Vector3d& p, Eigen::Vector3d* gradient,
                       Eigen::Matrix3d* gauss_newton) {
  gradient->setZero();
  if (gauss_newton != nullptr) gauss_newton->setZero();
  Eigen::Vector3d outward;
  const double s = NearestObstacleDistance(obstacles, p, &outward);
  if (!(s < thickness)) return 0.0;  // nothing within reach (or no obstacle)
  double penalty = 0.0;
  if (s < 0.0) {  // inside: phi(s) - phi(|s|), whose gradient is along the outward normal
    const double depth = -s;
    const double beyond = std::max(0.0, thickness - depth);
    penalty += 0.5 * ((thickness + depth) * (thickness + depth) - beyond * beyond);
    *gradient -= ((thickness + depth) + beyond) * outward;
    // Only the nearest face reaches when the depth is t or more: then the features add
    // nothing, and the Gauss-Newton part is phi(s)'s own.
    if (gauss_newton != nullptr && beyond == 0.0) *gauss_newton = outward * outward.transpose();
  }
  std::vector<FeatureDistance> features;
  for (const Obstacle* obstacle : obstacles) obstacle->FeaturesWithin(p, thickness, &features);
  for (const FeatureDistance& f : features) {
    const double gap = thickness - f.distance;
    penalty += 0.5 * f.weight * gap * gap;
    *gradient -= f.weight * gap * f.direction;
    if (gauss_newton != nullptr) *gauss_newton += f.weight * f.direction * f.direction.transpose();
  }
  if (gauss_newton != nullptr && !features.empty()) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(*gauss_newton);
    *gauss_newton = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() *
                    eigen.eigenvectors().transpose();
  }
  return penalty;
}

}  // namespace aqs
