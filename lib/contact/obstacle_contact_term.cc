#include "contact/obstacle_contact_term.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <ceres/cost_function.h>
#include <ceres/problem.h>
#include <glog/logging.h>

#include "contact/obstacle_penalty.h"

namespace aqs {

namespace {

class ObstacleCost final : public ceres::CostFunction {
 public:
  ObstacleCost(const std::vector<const Obstacle*>& obstacles, const PointStencil& point,
               double stiffness, double thickness)
      : obstacles_(obstacles), point_(point), stiffness_(stiffness), thickness_(thickness) {
    set_num_residuals(1);
    for (int j = 0; j < 4; ++j) mutable_parameter_block_sizes()->push_back(3);
  }

  // r = sqrt(2 k P(p)) (P clamped at 0), so that r^2 / 2 is the point's energy; where P
  // is one face's phi(d), r = sqrt(k) (t - d) and its Jacobian -sqrt(k) grad d^T dp/dx.
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Eigen::Vector3d p = point_.offset;
    for (int j = 0; j < 4; ++j) p += point_.weight[j] * Eigen::Map<const Eigen::Vector3d>(parameters[j]);
    Eigen::Vector3d g;
    const double penalty = ObstaclePenalty(obstacles_, thickness_, p, &g, nullptr);
    const double r = penalty > 0.0 ? std::sqrt(2.0 * stiffness_ * penalty) : 0.0;
    residuals[0] = r;
    if (jacobians == nullptr) return true;
    for (int j = 0; j < 4; ++j) {
      if (jacobians[j] == nullptr) continue;
      Eigen::Map<Eigen::RowVector3d> jac(jacobians[j]);
      if (r > 0.0) {
        jac = (stiffness_ * point_.weight[j] / r) * g.transpose();
      } else {
        jac.setZero();
      }
    }
    return true;
  }

 private:
  std::vector<const Obstacle*> obstacles_;
  PointStencil point_;
  double stiffness_;
  double thickness_;
};

}  // namespace

ObstacleContactTerm::ObstacleContactTerm(const std::vector<PointStencil>& points,
                                         const Eigen::VectorXd& stiffness, double thickness,
                                         const std::vector<const Obstacle*>& obstacles)
    : points_(points), stiffness_(stiffness), thickness_(thickness), obstacles_(obstacles) {
  CHECK_EQ(stiffness.size(), static_cast<Eigen::Index>(points.size()));
  CHECK_GT(thickness, 0.0);
}

double ObstacleContactTerm::Distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient,
                                     double max_distance) const {
  return NearestObstacleDistance(obstacles_, p, gradient, max_distance);
}

double ObstacleContactTerm::AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                                 Eigen::Matrix3Xd* gradient) const {
  double energy = 0.0;
  for (size_t i = 0; i < points_.size(); ++i) {
    const PointStencil& s = points_[i];
    Eigen::Vector3d g;
    const double penalty = ObstaclePenalty(obstacles_, thickness_, s.Position(x), &g, nullptr);
    if (penalty == 0.0 && g.isZero()) continue;
    energy += stiffness_[i] * penalty;
    for (int j = 0; j < 4; ++j) gradient->col(s.vertex[j]) += stiffness_[i] * s.weight[j] * g;
  }
  return energy;
}

void ObstacleContactTerm::AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                       const StiffnessPattern& pattern, StiffnessKind /*kind*/,
                                       std::vector<double>* values) const {
  // The point's Hessian projected positive semi-definite, for both kinds.
  for (size_t i = 0; i < points_.size(); ++i) {
    const PointStencil& s = points_[i];
    Eigen::Vector3d g;
    Eigen::Matrix3d h;
    ObstaclePenalty(obstacles_, thickness_, s.Position(x), &g, &h);
    if (h.isZero()) continue;
    h *= stiffness_[i];
    std::vector<int> vertices(s.vertex, s.vertex + 4);
    Eigen::MatrixXd hessian(12, 12);
    for (int j = 0; j < 4; ++j) {
      for (int l = 0; l < 4; ++l) hessian.block<3, 3>(3 * j, 3 * l) = s.weight[j] * s.weight[l] * h;
    }
    AddVertexHessian(vertices, hessian, pattern, values);
  }
}

ceres::CostFunction* ObstacleContactTerm::NewCostFunction(int i) const {
  return new ObstacleCost(obstacles_, points_[i], stiffness_[i], thickness_);
}

void ObstacleContactTerm::AddResidualBlocks(ceres::Problem* problem,
                                            const std::vector<double*>& vertex_blocks) const {
  for (size_t i = 0; i < points_.size(); ++i) {
    const PointStencil& s = points_[i];
    problem->AddResidualBlock(NewCostFunction(static_cast<int>(i)), nullptr,
                              vertex_blocks[s.vertex[0]], vertex_blocks[s.vertex[1]],
                              vertex_blocks[s.vertex[2]], vertex_blocks[s.vertex[3]]);
  }
}

}  // namespace aqs
