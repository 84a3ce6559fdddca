#ifndef AQS_CONTACT_SELF_CONTACT_TERM_H_
#define AQS_CONTACT_SELF_CONTACT_TERM_H_

#include <vector>

#include <Eigen/Core>

#include "contact/self_contact_pair.h"
#include "equilibrium/energy_term.h"

namespace ceres {
class CostFunction;
}

namespace aqs {

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
// (`outside` of SelfContactDistance <= margin); pairs are weighted by their fade
// (SelfContactFadeVariable: edge-edge pairs as their edges turn parallel, point-triangle
// pairs as their triangle flattens). The Ceres residual per pair is
// w sqrt(k) (thickness + offset - s) (0 when inactive; w the fade weight) with the exact
// derivative of s and w with respect to the four points (through the normal), chained to
// the simulation vertices of their stencils. Candidate pairs are chosen by ContactSolver
// (the side a point is on at rest, topological distance); they change between its rounds.
//
// Its stiffness (for Newton steps) is the exact Hessian of every active pair's energy,
// k (grad s grad s^T - (thickness + offset - s) Hess s), with the fade weight's
// derivatives for pairs inside their fade band. A pair couples the simulation
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

}  // namespace aqs

#endif  // AQS_CONTACT_SELF_CONTACT_TERM_H_
