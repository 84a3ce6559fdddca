#include "equilibrium/embedded_attachments.h"

#include <cmath>

#include <ceres/problem.h>
#include <ceres/sized_cost_function.h>
#include <glog/logging.h>

namespace aqs {
namespace {

// r = sqrt(k) (sum_j w_j x_j + o - y): 3 residuals, four vertex blocks; Jacobian block
// j is sqrt(k) w_j I (3x3, row-major). Reads the target through a pointer.
class AttachmentCostFunction final : public ceres::SizedCostFunction<3, 3, 3, 3, 3> {
 public:
  AttachmentCostFunction(const PointStencil& stencil, double stiffness, const double* target)
      : weights_(Eigen::Map<const Eigen::Vector4d>(stencil.weight)),
        offset_(stencil.offset),
        scale_(std::sqrt(stiffness)),
        target_(target) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    for (int c = 0; c < 3; ++c) {
      double p = 0.0;
      for (int j = 0; j < 4; ++j) p += weights_[j] * parameters[j][c];
      residuals[c] = scale_ * (p + offset_[c] - target_[c]);
    }
    if (jacobians == nullptr) return true;
    for (int j = 0; j < 4; ++j) {
      if (jacobians[j] == nullptr) continue;
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> jac(jacobians[j]);
      jac = scale_ * weights_[j] * Eigen::Matrix3d::Identity();
    }
    return true;
  }

 private:
  Eigen::Vector4d weights_;
  Eigen::Vector3d offset_;
  double scale_;
  const double* target_;
};

}  // namespace

ceres::CostFunction* NewAttachmentCostFunction(const PointStencil& stencil, double stiffness,
                                               const double* target) {
  return new AttachmentCostFunction(stencil, stiffness, target);
}

EmbeddedAttachments::EmbeddedAttachments(const Embedding& embedding, const Eigen::Matrix4Xi& tets,
                                         const Eigen::VectorXd& stiffness,
                                         const Eigen::Matrix3Xd& rest_positions)
    : stencils_(EmbeddingStencils(embedding, tets)), element_(embedding.element),
      stiffness_(stiffness) {
  CHECK_EQ(stiffness.size(), static_cast<Eigen::Index>(num_points()));
  for (int i = 0; i < num_points(); ++i) CHECK(stiffness[i] > 0.0) << "point " << i;
  targets_.resize(3 * element_.size());
  targets() = Points(rest_positions);
}

Eigen::Matrix3Xd EmbeddedAttachments::Points(const Eigen::Ref<const Eigen::Matrix3Xd>& x) const {
  Eigen::Matrix3Xd points(3, num_points());
  for (int i = 0; i < num_points(); ++i) points.col(i) = stencils_[i].Position(x);
  return points;
}

double EmbeddedAttachments::AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                                 Eigen::Matrix3Xd* gradient) const {
  double energy = 0.0;
  for (int i = 0; i < num_points(); ++i) {
    const PointStencil& s = stencils_[i];
    const Eigen::Vector3d d = s.Position(x) - targets().col(i);
    energy += 0.5 * stiffness_[i] * d.squaredNorm();
    for (int j = 0; j < 4; ++j) gradient->col(s.vertex[j]) += stiffness_[i] * s.weight[j] * d;
  }
  return energy;
}

void EmbeddedAttachments::AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                       const StiffnessPattern& pattern, StiffnessKind /*kind*/,
                                       std::vector<double>* values) const {
  // Constant and positive semi-definite: both kinds are the exact Hessian.
  // Hessian block (j, l) of point i: k_i w_ij w_il I3 on the element's vertex pair.
  for (int i = 0; i < num_points(); ++i) {
    const int e = element_[i];
    for (int j = 0; j < 4; ++j) {
      for (int l = 0; l < 4; ++l) {
        if (pattern.BlockOffset(e, j, l, 0) < 0) continue;
        const double h = stiffness_[i] * stencils_[i].weight[j] * stencils_[i].weight[l];
        // The 3x3 block is h I: only its diagonal entries (c == d) are non-zero.
        for (int d = 0; d < 3; ++d) (*values)[pattern.BlockOffset(e, j, l, d) + d] += h;
      }
    }
  }
}

void EmbeddedAttachments::AddResidualBlocks(ceres::Problem* problem,
                                            const std::vector<double*>& vertex_blocks) const {
  for (int i = 0; i < num_points(); ++i) {
    const PointStencil& s = stencils_[i];
    ceres::CostFunction* cost =
        NewAttachmentCostFunction(s, stiffness_[i], targets_.data() + 3 * i);
    problem->AddResidualBlock(cost, nullptr, vertex_blocks[s.vertex[0]], vertex_blocks[s.vertex[1]],
                              vertex_blocks[s.vertex[2]], vertex_blocks[s.vertex[3]]);
  }
}

}  // namespace aqs
