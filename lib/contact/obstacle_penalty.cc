#include "contact/obstacle_penalty.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

namespace aqs {
namespace {

// The features' distance curvature enters the Hessian with d no less than this fraction
// of the thickness: (t - d) / d grows without bound toward an edge or corner (t / r in a
// concave crease, and the round-off of the terms that cancel about a convex edge, as
// 1e-16 / d^2), and a stiffness of more than 100 times the penalty's own would freeze
// such a point in Newton steps and spoil the factorization.
constexpr double kCurvatureFloor = 0.01;

}  // namespace

double NearestObstacleDistance(const std::vector<const Obstacle*>& obstacles,
                               const Eigen::Vector3d& p, Eigen::Vector3d* gradient,
                               double max_distance) {
  double best = max_distance;
  gradient->setZero();
  for (const Obstacle* obstacle : obstacles) {
    Eigen::Vector3d g;
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
                       Eigen::Matrix3d* hessian) {
  gradient->setZero();
  if (hessian != nullptr) hessian->setZero();
  // Scratch kept per thread (this runs for every contact point at every evaluation).
  thread_local std::vector<FeatureDistance> features;
  features.clear();
  double penalty = 0.0;
  for (const Obstacle* obstacle : obstacles) {
    Eigen::Vector3d outward;
    // Searched only within the thickness (points inside at any depth).
    const double s = obstacle->SignedDistance(p, &outward, thickness);
    if (!(s < thickness)) continue;  // out of reach
    if (s < 0.0) {  // inside: phi(s) - phi(|s|), whose gradient is along the outward normal
      const double depth = -s;
      const double beyond = std::max(0.0, thickness - depth);
      penalty += 0.5 * ((thickness + depth) * (thickness + depth) - beyond * beyond);
      *gradient -= ((thickness + depth) + beyond) * outward;
      // When the depth is t or more no feature of this obstacle reaches; phi(s)'s
      // Hessian then, its curvature left out, is n n^T.
      if (hessian != nullptr && beyond == 0.0) *hessian += outward * outward.transpose();
    }
    const size_t first = features.size();
    obstacle->FeaturesWithin(p, thickness, &features);
    // On the surface (within 1e-12) the features whose closest point is p have no
    // direction of their own. Their weights add up to 1 (the count of the point itself),
    // and each takes the direction p - q has just off the surface: the obstacle's outward
    // normal there, or inward when the point counts as inside (its depth term then pushes
    // out with 2 t), so that the gradient is -t n either way, as on either side.
    for (size_t i = first; i < features.size(); ++i) {
      if (features[i].distance <= 1e-12) features[i].direction = s < 0.0 ? -outward : outward;
    }
  }
  for (const FeatureDistance& f : features) {
    const double gap = thickness - f.distance;
    penalty += 0.5 * f.weight * gap * gap;
    *gradient -= f.weight * gap * f.direction;
    if (hessian != nullptr) {
      *hessian += f.weight * (f.direction * f.direction.transpose() -
                              gap * FeatureDistanceHessian(f, kCurvatureFloor * thickness));
    }
  }
  if (hessian != nullptr && !features.empty()) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(*hessian);
    *hessian = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() *
                    eigen.eigenvectors().transpose();
  }
  return penalty;
}

}  // namespace aqs
