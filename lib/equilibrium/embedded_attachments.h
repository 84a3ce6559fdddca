#ifndef AQS_EQUILIBRIUM_EMBEDDED_ATTACHMENTS_H_
#define AQS_EQUILIBRIUM_EMBEDDED_ATTACHMENTS_H_

#include <vector>

#include <Eigen/Core>

#include "equilibrium/energy_term.h"
#include "geometry/embedding.h"

namespace ceres {
class CostFunction;
}

namespace aqs {

// Zero-rest-length springs that pull embedded points towards targets:
//
//   E_att(x) = sum_i k_i / 2 | p_i(x) - y_i |^2,   p_i(x) = sum_j w_ij x_{v_ij} + o_i,
//
// where p_i is point i of an embedding (EmbeddingStencil: weights w_i in element
// element[i], its four vertices v_ij = tets(j, element[i]), offset o_i). Used to pull
// an embedded surface onto a captured pose (volumetric targets by embedded
// simulation). Targets are changed in place between solves (targets()).
class EmbeddedAttachments : public EnergyTerm {
 public:
  // embedding: the n points, embedded in the elements tets (the model's 4 x
  // num_elements); stiffness: one k_i > 0 per point. Targets start at the points'
  // positions for `rest_positions` (3 x num_vertices).
  EmbeddedAttachments(const Embedding& embedding, const Eigen::Matrix4Xi& tets,
                      const Eigen::VectorXd& stiffness, const Eigen::Matrix3Xd& rest_positions);

  int num_points() const { return static_cast<int>(element_.size()); }
  // Target positions (3 x num_points), changed in place between solves (a view of
  // storage this object owns and its cost functions read; assignment copies into it).
  Eigen::Map<Eigen::Matrix3Xd> targets() {
    return Eigen::Map<Eigen::Matrix3Xd>(targets_.data(), 3, num_points());
  }
  Eigen::Map<const Eigen::Matrix3Xd> targets() const {
    return Eigen::Map<const Eigen::Matrix3Xd>(targets_.data(), 3, num_points());
  }
  // The embedded points p_i(x), offsets included (3 x num_points), for positions x
  // (3 x num_vertices): EmbeddedPositions of the embedding.
  Eigen::Matrix3Xd Points(const Eigen::Ref<const Eigen::Matrix3Xd>& x) const;

  double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                              Eigen::Matrix3Xd* gradient) const override;
  void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x, const StiffnessPattern& pattern,
                    StiffnessKind kind, std::vector<double>* values) const override;
  bool HasConstantHessian() const override { return true; }
  void AddResidualBlocks(ceres::Problem* problem,
                         const std::vector<double*>& vertex_blocks) const override;

 private:
  std::vector<PointStencil> stencils_;  // p_i(x)
  std::vector<int> element_;
  Eigen::VectorXd stiffness_;
  std::vector<double> targets_;  // 3 x num_points, never reallocated
};

// The Ceres cost function of one attachment: residual sqrt(k) (sum_j w_j x_j + o - y)
// (3 residuals; w, o: the stencil's weights and offset) over the four vertex blocks of
// the stencil, Jacobian block j = sqrt(k) w_j I (3x3, row-major); reads y (3 doubles)
// through `target` at every evaluation. Exposed for tests;
// EmbeddedAttachments::AddResidualBlocks creates these.
ceres::CostFunction* NewAttachmentCostFunction(const PointStencil& stencil, double stiffness,
                                               const double* target);

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_EMBEDDED_ATTACHMENTS_H_
