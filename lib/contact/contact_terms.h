#ifndef AQS_CONTACT_CONTACT_TERMS_H_
#define AQS_CONTACT_CONTACT_TERMS_H_

#include <vector>

#include <Eigen/Core>

#include "contact/obstacle.h"
#include "contact/surface_stencils.h"
#include "equilibrium/energy_term.h"

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
// Levenberg-Marquardt only (no stiffness).
class ObstacleContactTerm : public EnergyTerm {
 public:
  ObstacleContactTerm(const std::vector<PointStencil>& points, const Eigen::VectorXd& stiffness,
                      double thickness, const std::vector<const Obstacle*>& obstacles);

  bool SupportsStiffness() const override { return false; }
  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override;
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x, const StiffnessPattern& pattern,
                    std::vector<double>* values) const override;
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

// One self-contact candidate: surface point `point` against the surface triangle whose
// corners are the surface points corner[0..2], with stiffness k.
struct SelfContactPair {
  PointStencil point;
  PointStencil corner[3];
  double stiffness = 0.0;
  // Augmented-Lagrangian shift: the pair keeps the point thickness + offset in front of
  // the plane (offset = multiplier / stiffness; ContactSolver updates it between rounds
  // so that the point ends at the thickness despite a finite stiffness).
  double offset = 0.0;
  int surface_vertex = -1;  // the point's surface vertex (reporting only)
};

// Contact between parts of the simulated surface, for fixed candidate pairs (point,
// triangle), as a penalty on the signed distance of the point to the triangle's plane,
// s = n . (p - P0) with n the unit normal of (P1 - P0) x (P2 - P0):
//
//   E = sum_pairs k / 2 (thickness + offset - s)^2   where active,
//
// (offset: the pair's augmented-Lagrangian shift, 0 for a plain penalty), active when
// s < thickness + offset, s > -max_depth and the point projects into the triangle
// (barycentric coordinates >= -margin). The Ceres residual per pair is
// sqrt(k) (thickness + offset - s) (0 when inactive) with the exact derivative of s with respect
// to the point and the three corners (through the normal), chained to the simulation
// vertices of their stencils. Candidate pairs are chosen by ContactSolver (the side a
// point is on at rest, topological distance); they change between its rounds.
// Levenberg-Marquardt only (no stiffness).
class SelfContactTerm : public EnergyTerm {
 public:
  SelfContactTerm(const std::vector<SelfContactPair>& pairs, double thickness, double max_depth,
                  double margin);

  bool SupportsStiffness() const override { return false; }
  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override;
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x, const StiffnessPattern& pattern,
                    std::vector<double>* values) const override;
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

}  // namespace aqs

#endif  // AQS_CONTACT_CONTACT_TERMS_H_
