#ifndef AQS_FIT_FIT_TARGET_H_
#define AQS_FIT_FIT_TARGET_H_

#include <string>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// What to fit: K target points, each a point of the model's surface given as a
// barycentric combination of up to three surface vertices (vertices(., k) with weights
// barycentric(., k); a single vertex is (v, v, v) with (1, 0, 0)), and the position it
// should take. Optional per-point weights (empty: all 1).
struct FitTarget {
  Eigen::Matrix3Xi vertices;
  Eigen::Matrix3Xd barycentric;
  Eigen::Matrix3Xd positions;
  Eigen::VectorXd weights;
  // Optional unit normals (3 x K; empty: point-to-point). With them the residual of
  // point k is P_k (p_k - y_k), P_k = n n^T + tangential_weight (I - n n^T): the
  // distance to the target's tangent plane plus a fraction of the distance along it
  // (point-to-plane matching of scans, which lets surfaces slide).
  Eigen::Matrix3Xd normals;
  double tangential_weight = 1.0;

  int num_points() const { return static_cast<int>(positions.cols()); }
};

// Checks a target as data for a model with `num_surface_vertices` surface vertices: at
// least one point; vertices and barycentric 3 x K, weights and normals empty or K
// columns; every vertex in [0, num_surface_vertices); finite barycentric coordinates,
// positions and normals; finite weights >= 0 with a positive sum; a finite tangential
// weight >= 0. Returns false with *error naming the first problem (point k, its
// vertex). (A NaN position made a fit "succeed" with a NaN error; an empty target,
// negative weights or a vertex of another mesh aborted.)
bool ValidateFitTarget(const FitTarget& target, int num_surface_vertices, std::string* error);

// Targets on single surface vertices (markers): vertex v_k at positions.col(k).
FitTarget VertexTarget(const std::vector<int>& vertices, const Eigen::Matrix3Xd& positions);
// All surface vertices at `surface` (3 x num_surface_vertices): a pose with known
// correspondence.
FitTarget FullSurfaceTarget(const Eigen::Matrix3Xd& surface);

// The sum of the target's weights (the number of points without weights).
double TotalWeight(const FitTarget& target);
// W of the fits' prior weights: the total weight, capped at `cap` (<= 0: no cap).
double PriorPoints(const FitTarget& target, double cap);
// The same for points of this total weight (K for K points without weights).
double PriorPoints(double total_weight, double cap);
// The target's points on a surface (3 x num_surface_vertices): 3 x K, column k the
// barycentric combination of its vertices.
Eigen::Matrix3Xd TargetPointsOn(const FitTarget& target, const Eigen::Matrix3Xd& surface);
// The target's data term on a surface: (1/sum w) sum_k w_k |P_k (p_k - y_k)|^2, p_k the
// target points on it, P_k the point-to-plane projector where the target has normals,
// else the identity.
double TargetDataTerm(const FitTarget& target, const Eigen::Matrix3Xd& surface);

}  // namespace aqs

#endif  // AQS_FIT_FIT_TARGET_H_
