#ifndef AQS_CONTACT_SELF_CONTACT_PAIR_H_
#define AQS_CONTACT_SELF_CONTACT_PAIR_H_

#include <Eigen/Core>

#include "geometry/embedding.h"

namespace aqs {

// One self-contact candidate, of one of two kinds:
//  - point-triangle (kPointTriangle): surface point `point` against the surface triangle
//    whose corners are the surface points corner[0..2];
//  - edge-edge (kEdgeEdge): the surface edge (point, corner[0]) against the surface edge
//    (corner[1], corner[2]), for crossings in which no corner passes through a triangle.
// k is the pair's penalty stiffness.
struct SelfContactPair {
  enum class Kind { kPointTriangle, kEdgeEdge };
  Kind kind = Kind::kPointTriangle;
  PointStencil point;
  PointStencil corner[3];
  double stiffness = 0.0;
  // Edge-edge: +1 or -1, the side of the second edge the first one keeps, as the sign of
  // EdgeDistance (ContactSolver takes it from the surface normals where the edges were
  // apart); point-triangle pairs keep the positive side (+1).
  double sign = 1.0;
  // Augmented-Lagrangian shift: the pair keeps its distance at least thickness + offset
  // (offset = multiplier / stiffness; ContactSolver updates it between rounds so that the
  // pair ends at the thickness despite a finite stiffness).
  double offset = 0.0;
  // Bookkeeping for ContactSolver (not used by the term): the point's surface vertex
  // (point-triangle) or the two edges' indices, the lower first (edge-edge).
  int surface_vertex = -1;
  int edge = -1;
  int second_edge = -1;
};

// The signed distance s of a pair at the positions of its four stencils (points[0] =
// point, points[1..3] = corners), its gradient with respect to them (3 x 4, columns in
// that order; null: not computed) and how far outside its feature the closest points
// are (*outside: point-triangle: -min barycentric coordinate of the projection;
// edge-edge: the largest distance of the closest-point parameters outside [0, 1]; <= 0
// inside). Point-triangle: PlaneDistance; edge-edge: sign * EdgeDistance (any angle but
// parallel). Returns false where undefined (degenerate triangle, parallel edges).
bool SelfContactDistance(const SelfContactPair& pair, const Eigen::Vector3d points[4], double* s,
                         Eigen::Matrix<double, 3, 4>* gradient, double* outside);

// The Hessian of a self-contact pair's signed distance s (SelfContactDistance, with the
// pair's sign) with respect to its four points (12 x 12; rows and columns point, then
// corners, x y z each): PlaneDistanceHessian or sign * EdgeDistanceHessian. Returns
// false where s is undefined.
bool SelfContactDistanceHessian(const SelfContactPair& pair, const Eigen::Vector3d points[4],
                                Eigen::Matrix<double, 12, 12>* hessian);

// Pairs fade out where their distance is ill-conditioned (its gradient levered by a
// small sine or a small triangle height): the residual is scaled by the weight
// w = sqrt(smoothstep(x)), x = (f - zero) / (full - zero) of a fade variable f
// (SelfContactFadeVariable), so that the energy w^2 k / 2 (...)^2 stays C1.
//  - Edge-edge pairs, as their edges turn parallel (where the lines' distance normal
//    flips): f = EdgeSine, band kEdgeFadeSine .. kFullEdgeSine; ContactSolver pairs only
//    edges with sine >= kMinEdgeSine.
//  - Point-triangle pairs, as their triangle flattens (a triangle squashed in a pose:
//    the plane's normal turns by (point offset) / (height) per unit corner motion):
//    f = TriangleQuality, band kTriangleFadeQuality .. kFullTriangleQuality; ContactSolver
//    pairs only triangles with quality >= kMinTriangleQuality (the ICT face's rest
//    surface has none below 0.045).
constexpr double kEdgeFadeSine = 0.05;
constexpr double kFullEdgeSine = 0.15;
constexpr double kMinEdgeSine = 0.2;
constexpr double kTriangleFadeQuality = 0.01;
constexpr double kFullTriangleQuality = 0.02;
constexpr double kMinTriangleQuality = 0.03;

// Whether the surface triangle (a, b, c) may take part in a point-triangle pair:
// TriangleQuality >= kMinTriangleQuality (false for a degenerate triangle).
bool PairableTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                      const Eigen::Vector3d& c);

// A pair's fade band: the fade variable's values at weight 0 (zero) and 1 (full).
struct SelfContactFadeBand {
  double zero = 0.0;
  double full = 0.0;
};
SelfContactFadeBand FadeBandOf(const SelfContactPair& pair);

// The pair's fade variable f at its four points (points[0] = point, points[1..3] =
// corners; as SelfContactDistance) and its gradient with respect to them (3 x 4; null: not
// computed): EdgeSine of the two edges, or TriangleQuality of the corners (the point's
// column 0). Returns false where undefined (a degenerate edge or triangle).
bool SelfContactFadeVariable(const SelfContactPair& pair, const Eigen::Vector3d points[4],
                             double* value, Eigen::Matrix<double, 3, 4>* gradient);

// Its Hessian with respect to the four points (12 x 12, ordered as
// SelfContactDistanceHessian). Returns false where it is not smooth (parallel edges, a
// flat triangle).
bool SelfContactFadeVariableHessian(const SelfContactPair& pair, const Eigen::Vector3d points[4],
                                    Eigen::Matrix<double, 12, 12>* hessian);

}  // namespace aqs

#endif  // AQS_CONTACT_SELF_CONTACT_PAIR_H_
