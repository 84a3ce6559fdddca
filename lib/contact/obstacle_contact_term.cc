#include "contact/obstacle_contact_term.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <ceres/cost_function.h>
#include <ceres/problem.h>
#include <glog/logging.h>

namespace aqs {

namespace {

class ObstacleCost final : public ceres::CostFunction {
 public:
  ObstacleCost(const ObstacleContactTerm& term, const PointStencil& point, double stiffness,
               double thickness)
      : term_(term), point_(point), scale_(std::sqrt(stiffness)), thickness_(thickness) {
    set_num_residuals(1);
    for (int j = 0; j < 4; ++j) mutable_parameter_block_sizes()->push_back(3);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Eigen::Vector3d p = point_.offset;
    for (int j = 0; j < 4; ++j) p += point_.weight[j] * Eigen::Map<const Eigen::Vector3d>(parameters[j]);
    Eigen::Vector3d g;
    const double d = term_.Distance(p, &g);
    const bool active = d < thickness_;
    residuals[0] = active ? scale_ * (thickness_ - d) : 0.0;
    if (jacobians == nullptr) return true;
    for (int j = 0; j < 4; ++j) {
      if (jacobians[j] == nullptr) continue;
      Eigen::Map<Eigen::RowVector3d> jac(jacobians[j]);
      if (active) {
        jac = -scale_ * point_.weight[j] * g.transpose();
      } else {
        jac.setZero();
      }
    }
    return true;
  }

 private:
  const ObstacleContactTerm& term_;
  PointStencil point_;
  double scale_;
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

double ObstacleContactTerm::Distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient) const {
  double best = std::numeric_limits<double>::infinity();
  gradient->setZero();
  for (const Obstacle* obstacle : obstacles_) {
    Eigen::Vector3d g;
    // Beyond a few thicknesses the exact distance does not matter.
    const double d = obstacle->SignedDistance(p, &g, std::max(10.0 * thickness_, std::min(best, 1e300)));
    if (d < best) {
      best = d;
      *gradient = g;
    }
  }
  return best;
}

double ObstacleContactTerm::AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                                 Eigen::Matrix3Xd* gradient) const {
  double energy = 0.0;
  for (size_t i = 0; i < points_.size(); ++i) {
    const PointStencil& s = points_[i];
    Eigen::Vector3d g;
    const double d = Distance(s.Position(x), &g);
    if (!(d < thickness_)) continue;
    const double gap = thickness_ - d;
    energy += 0.5 * stiffness_[i] * gap * gap;
    for (int j = 0; j < 4; ++j) gradient->col(s.vertex[j]) -= stiffness_[i] * gap * s.weight[j] * g;
  }
  return energy;
}

void ObstacleContactTerm::AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                       const StiffnessPattern& pattern, StiffnessKind /*kind*/,
                                       std::vector<double>* values) const {
  // The Gauss-Newton part (positive semi-definite) for both kinds.
  for (size_t i = 0; i < points_.size(); ++i) {
    const PointStencil& s = points_[i];
    Eigen::Vector3d g;
    if (!(Distance(s.Position(x), &g) < thickness_)) continue;
    const Eigen::Matrix3d h = stiffness_[i] * g * g.transpose();
    std::vector<int> vertices(s.vertex, s.vertex + 4);
    Eigen::MatrixXd hessian(12, 12);
    for (int j = 0; j < 4; ++j) {
      for (int l = 0; l < 4; ++l) hessian.block<3, 3>(3 * j, 3 * l) = s.weight[j] * s.weight[l] * h;
    }
    AddVertexHessian(vertices, hessian, pattern, values);
  }
}

ceres::CostFunction* ObstacleContactTerm::NewCostFunction(int i) const {
  return new ObstacleCost(*this, points_[i], stiffness_[i], thickness_);
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
