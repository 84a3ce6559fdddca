#ifndef AQS_CONTACT_OBSTACLE_CONTACT_TERM_H_
#define AQS_CONTACT_OBSTACLE_CONTACT_TERM_H_

#include <limits>
#include <vector>

#include <Eigen/Core>

#include "contact/obstacle.h"
#include "geometry/embedding.h"
#include "equilibrium/energy_term.h"

namespace ceres {
class CostFunction;
}

namespace aqs {

// Contact with rigid obstacles as a penalty on embedded surface points p_i(x):
//
//   E = sum_i k_i P(p_i),
//
// P the point's penalty (ObstaclePenalty, contact/obstacle_penalty.h): 1/2 max(0,
// thickness - d(p_i))^2, d the signed distance to the nearest obstacle (negative inside),
// wherever the features of the obstacles within reach share their closest point, and a
// C1 sum over those features where they do not (a concave crease), so that Newton steps
// do not crawl there. Its Ceres residual per point is r_i = sqrt(2 k_i P(p_i)), with the
// exact Jacobian k_i grad P^T dp_i/dx / r_i. The features are found anew at every
// evaluation (obstacle trees), so contacts follow the solve. Its stiffness (for Newton
// steps) is each point's Hessian projected positive semi-definite (ObstaclePenalty:
// exact outside the obstacles); a point's stencil lies in one element, so it needs no
// extra couplings.
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
  // Signed distance of a point to the nearest obstacle and its gradient
  // (NearestObstacleDistance, searched as far as max_distance): what the reports count as
  // contact (d < thickness) and candidates are chosen by.
  double Distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient,
                  double max_distance = std::numeric_limits<double>::infinity()) const;

 private:
  std::vector<PointStencil> points_;
  Eigen::VectorXd stiffness_;
  double thickness_;
  std::vector<const Obstacle*> obstacles_;
};

}  // namespace aqs

#endif  // AQS_CONTACT_OBSTACLE_CONTACT_TERM_H_
