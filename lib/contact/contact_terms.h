#ifndef AQS_CONTACT_CONTACT_TERMS_H_
#define AQS_CONTACT_CONTACT_TERMS_H_

#include <vector>

#include <Eigen/Core>

#include "contact/obstacle.h"
#include "equilibrium/energy_term.h"
#include "geometry/embedding.h"

namespace ceres {
class CostFunction;
}

namespace aqs {

// Contact with rigid obstacles as a penalty on embedded surface points p_i(x):
//
//   E = sum_i k_i / 2 max(0, thickness - d(p_i))^2,
//
// d the signed distance to the nearest obstacle (Obstacle::SignedDistance: negative
// inside). Its Ceres residual per point is r_i = sqrt(k_i) max(0, thickness - d(p_i)),
// whose Jacobian -sqrt(k_i) grad d(p_i)^T dp_i/dx is exact wherever the closest obstacle
// feature is unique (grad d is the unit vector from the closest point). The closest
// point is found anew at every evaluation (obstacle trees), so contacts follow the solve.
// Its stiffness (for Newton steps) is the Gauss-Newton part k_i grad d grad d^T of each
// active point, exact where the closest obstacle feature is a face (there Hess d = 0);
// a point's stencil lies in one element, so it needs no extra couplings.
class ObstacleContactTerm : public EnergyTerm {
 public:
  ObstacleContactTerm(const std::vector<PointStencil>& points, const Eigen::VectorXd& stiffness,
                      double thickness, const std::vector<const Obstacle*>& obstacles);

  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override;
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x, const StiffnessPattern& pattern,
                    StiffnessKind kind, std::vector<double>* values) const override;
  void AddResidualBlocks(ceres::Problem* problem,
                         const std::vector<double*>& vertex_blocks) const override;

  // The residual cost function of point i (1 residual, 4 blocks of 3), for tests.
  ceres::CostFunction* NewCostFunction(int i) const;
  // Signed distance of a point to the nearest obstacle (and its gradient).
  double Distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient) const;

 private:
  std::vector<PointStencil> points_;
  Eigen::VectorXd stiffness_;
  double thickness_;
  std::vector<const Obstacle*> obstacles_;
};

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
  // (point-triangle) or the first edge's index (edge-edge).
  int surface_vertex = -1;
  int edge = -1;
};

// The signed distance s of a pair at the positions of its four stencils (points[0] =
// point, points[1..3] = corners), its gradient with respect to them (3 x 4, columns in
// that order) and how far outside its feature the closest points are (*outside: point-
// triangle: -min barycentric coordinate of the projection; edge-edge: the largest
// distance of the closest-point parameters outside [0, 1]; <= 0 inside). Point-triangle:
// PlaneDistance; edge-edge: sign * EdgeDistance (any angle but parallel). Returns false
// where undefined (degenerate triangle, parallel edges).
bool SelfContactDistance(const SelfContactPair& pair, const Eigen::Vector3d points[4], double* s,
                         Eigen::Matrix<double, 3, 4>* gradient, double* outside);

// Contact between parts of the simulated surface, for fixed candidate pairs, as a
// penalty on their signed distance s (SelfContactDistance): for a point and a triangle,
// the distance of the point to the triangle's plane, s = n . (p - P0) with n the unit
// normal of (P1 - P0) x (P2 - P0); for two edges, the distance between their lines along
// their common normal, with the pair's sign:
//
//   E = sum_pairs k / 2 (thickness + offset - s)^2   where active,
//
// (offset: the pair's augmented-Lagrangian shift, 0 for a plain penalty), active when
// s < thickness + offset, s > -max_depth and the closest points lie on the features
// (`outside` of SelfContactDistance <= margin); edge-edge pairs are weighted by the fade
// of kEdgeFadeSine. The Ceres residual per pair is
// sqrt(k) (thickness + offset - s) (0 when inactive) with the exact derivative of s with
// respect to the four points (through the normal), chained to the simulation vertices of
// their stencils. Candidate pairs are chosen by ContactSolver (the side a point is on at
// rest, topological distance); they change between its rounds.
//
// Its stiffness (for Newton steps) is the exact Hessian of every active pair's energy,
// k (grad s grad s^T - (thickness + offset - s) Hess s), with the fade weight's
// derivatives for edge-edge pairs inside the fade band. A pair couples the simulation
// vertices of its four stencils (AppendVertexCouplings).
class SelfContactTerm : public EnergyTerm {
 public:
  SelfContactTerm(const std::vector<SelfContactPair>& pairs, double thickness, double max_depth,
                  double margin);

  void AppendVertexCouplings(std::vector<std::vector<int>>* couplings) const override;
  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override;
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x, const StiffnessPattern& pattern,
                    StiffnessKind kind, std::vector<double>* values) const override;
  void AddResidualBlocks(ceres::Problem* problem,
                         const std::vector<double*>& vertex_blocks) const override;

  int num_pairs() const { return static_cast<int>(pairs_.size()); }
  // The residual cost function of pair i and its parameter blocks' vertex indices
  // (unique simulation vertices, in block order), for tests.
  ceres::CostFunction* NewCostFunction(int i, std::vector<int>* block_vertices) const;

 private:
  std::vector<SelfContactPair> pairs_;
  double thickness_;
  double max_depth_;
  double margin_;
};

// The plane distance s = n . (p - a), n = unit((b - a) x (c - a)), and its gradient with
// respect to p, a, b, c (3 x 4, columns in that order). Returns false for a degenerate
// triangle. Also the barycentric coordinates of p's projection onto the plane.
bool PlaneDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                   const Eigen::Vector3d& c, double* s, Eigen::Matrix<double, 3, 4>* gradient,
                   Eigen::Vector3d* barycentric);

// The distance between the lines of the edges (pa, pb) and (qa, qb) along their common
// normal, s = n . (pa - qa), n = unit((pb - pa) x (qb - qa)), and its gradient with
// respect to pa, pb, qa, qb (3 x 4, columns in that order). Also the parameters of the
// lines' closest points, pa + u (pb - pa) and qa + v (qb - qa) (in [0, 1] where the
// closest points lie on the edges). Returns false when the edges are parallel within
// min_sine (|sin angle| <= min_sine) or degenerate: s is then ill-conditioned.
bool EdgeDistance(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& qa,
                  const Eigen::Vector3d& qb, double min_sine, double* s,
                  Eigen::Matrix<double, 3, 4>* gradient, double* u, double* v);

// The Hessian of a self-contact pair's signed distance s (SelfContactDistance, with the
// pair's sign) with respect to its four points (12 x 12; rows and columns point, then
// corners, x y z each). Both kinds are s = unit(u x v) . w for differences u, v, w of
// the points (point-triangle: u = P1 - P0, v = P2 - P0, w = p - P0; edge-edge:
// u = pb - pa, v = qb - qa, w = pa - qa). Returns false where s is undefined.
bool SelfContactDistanceHessian(const SelfContactPair& pair, const Eigen::Vector3d points[4],
                                Eigen::Matrix<double, 12, 12>* hessian);

// Edge-edge pairs fade out as their edges turn parallel (where the lines' distance is
// ill-conditioned and its normal flips): the residual is scaled by
// sqrt(smoothstep((sine - kEdgeFadeSine) / (kFullEdgeSine - kEdgeFadeSine))), so that the
// energy stays C1; ContactSolver pairs only edges with sine >= kMinEdgeSine.
constexpr double kEdgeFadeSine = 0.05;
constexpr double kFullEdgeSine = 0.15;
constexpr double kMinEdgeSine = 0.2;

// |sin angle| between the edges (pb - pa) and (qb - qa) and its gradient with respect to
// pa, pb, qa, qb (3 x 4). Returns false for a degenerate edge.
bool EdgeSine(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& qa,
              const Eigen::Vector3d& qb, double* sine, Eigen::Matrix<double, 3, 4>* gradient);
// Its Hessian with respect to pa, pb, qa, qb (12 x 12, x y z of each point in turn).
// Returns false for a degenerate edge or parallel edges (where the sine is not smooth).
bool EdgeSineHessian(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb,
                     const Eigen::Vector3d& qa, const Eigen::Vector3d& qb,
                     Eigen::Matrix<double, 12, 12>* hessian);

}  // namespace aqs

#endif  // AQS_CONTACT_CONTACT_TERMS_H_
