#ifndef AQS_CONTACT_OBSTACLE_PENALTY_H_
#define AQS_CONTACT_OBSTACLE_PENALTY_H_

#include <limits>
#include <vector>

#include <Eigen/Core>

#include "contact/obstacle.h"

namespace aqs {

// The contact penalty of one point p against rigid obstacles, per unit stiffness, with
// phi(d) = 1/2 max(0, t - d)^2 (t = thickness > 0):
//
//   P(p) = sum_f w_f phi(d_f(p))  +  sum_o [phi(s_o(p)) - phi(|s_o(p)|)],
//
// the first sum over the closed features f (triangles, edges, vertices) of every obstacle
// nearer than t, d_f the unsigned distance to f and w_f its inclusion-exclusion weight
// (Obstacle::FeaturesWithin); s_o the signed distance to obstacle o (negative inside:
// Obstacle::SignedDistance). Outside every obstacle the second sum vanishes and P is the
// feature sum: phi(d) of the nearest distance wherever the closest points of the
// features within reach coincide (over a face, a convex edge or corner, a flat
// tessellation), C1 at a concave crease, where phi(d) kinks (its gradient jumps between
// the two faces' normals, and Newton steps crawl along it: docs/solver.md, "Stalls"), and
// the penalties of several obstacles add. A part of an obstacle thinner than about 2 t (or
// an obstacle smaller than that) is counted from both sides: up to twice phi(d). Inside
// obstacle o, phi(s_o) - phi(|s_o|) = 2 t |s_o| (or 1/2 (t + |s_o|)^2 past t) adds its
// depth, so P is continuous through each surface, and a point inside several obstacles
// that overlap (shells of one model: SplitIntoShells) is pushed out of each; the gradient
// still kinks at the interior bisector of a convex edge, where the nearest face changes.
//
// Returns P; *gradient = dP/dp; *hessian (may be null) = d2P/dp2 with its negative
// eigenvalues set to 0. Before that projection it is exact outside the obstacles, at
// least t / 100 from every feature's closest point: sum_f w_f (n_f n_f^T - (t - d_f)
// Hess d_f) over the features within reach (n_f = grad d_f, Hess d_f =
// FeatureDistanceHessian). The curvature part is negative about convex edges and corners
// (removed by the projection) and positive in concave creases, from the edges of weight
// < 0; nearer than t / 100 to an edge or corner it is that at t / 100 (bounded). Inside an
// obstacle its depth term adds n n^T only (the depth's curvature is left out). On the
// surface (within 1e-12) the features that hold the point take the obstacle's normal
// there, so that the gradient is -t n, as on either side. P >= 0.
double ObstaclePenalty(const std::vector<const Obstacle*>& obstacles, double thickness,
                       const Eigen::Vector3d& p, Eigen::Vector3d* gradient,
                       Eigen::Matrix3d* hessian);

// The signed distance of p to the nearest of `obstacles` (Obstacle::SignedDistance, each
// obstacle searched only as far as max_distance and the nearest so far, penetrations at
// any depth) and its gradient; max_distance with a zero gradient when none is nearer
// (+infinity: when there are no obstacles).
double NearestObstacleDistance(
    const std::vector<const Obstacle*>& obstacles, const Eigen::Vector3d& p,
    Eigen::Vector3d* gradient,
    double max_distance = std::numeric_limits<double>::infinity());

}  // namespace aqs

#endif  // AQS_CONTACT_OBSTACLE_PENALTY_H_
