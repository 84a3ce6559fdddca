#ifndef AQS_CONTACT_OBSTACLE_PENALTY_H_
#define AQS_CONTACT_OBSTACLE_PENALTY_H_

#include <vector>

#include <Eigen/Core>

#include "contact/obstacle.h"

namespace aqs {

// The contact penalty of one point p against rigid obstacles, per unit stiffness, with
// phi(d) = 1/2 max(0, t - d)^2 (t = thickness > 0):
//
//   P(p) = sum_f w_f phi(d_f(p))  +  phi(s(p)) - phi(|s(p)|),
//
// the first sum over the closed features f (triangles, edges, vertices) of every obstacle
// nearer than t, d_f the unsigned distance to f and w_f its inclusion-exclusion weight
// (Obstacle::FeaturesWithin); s the signed distance to the nearest obstacle (negative
// inside: Obstacle::SignedDistance). Outside every obstacle the last two cancel and P is
// the feature sum: phi(s) wherever the closest points of the features within reach
// coincide (over a face, a convex edge or corner, a flat tessellation), C1 at a concave
// crease, where phi(s) kinks (its gradient jumps between the two faces' normals, and
// Newton steps crawl along the crease: docs/solver.md, "Stalls"), and the penalties of
// several obstacles add. Inside, phi(s) - phi(|s|) = 2 t |s| (or 1/2 (t + |s|)^2 past t)
// adds the depth, so P is continuous through the surface; its gradient still kinks at
// the interior bisector of a convex edge, where the nearest face changes.
//
// Returns P; *gradient = dP/dp; *gauss_newton (may be null) = the Gauss-Newton part of
// the Hessian, sum_f w_f n_f n_f^T over the features within reach (n_f = grad d_f), with
// its negative eigenvalues (from edges of weight < 0) set to 0. It omits the distances'
// curvature, sum_f -w_f (t - d_f) Hess d_f, which is 0 where all features are faces.
double ObstaclePenalty(const std::vector<const Obstacle*>& obstacles, double thickness,
                       const Eigen::Vector3d& p, Eigen::Vector3d* gradient,
                       Eigen::Matrix3d* gauss_newton);

// The signed distance of p to the nearest of `obstacles` (Obstacle::SignedDistance; each
// obstacle after the first searched only as far as the nearest so far, penetrations at
// any depth) and its gradient; +infinity with a zero gradient when there are no
// obstacles.
double NearestObstacleDistance(const std::vector<const Obstacle*>& obstacles,
                               const Eigen::Vector3d& p, Eigen::Vector3d* gradient);

}  // namespace aqs

#endif  // AQS_CONTACT_OBSTACLE_PENALTY_H_
