#ifndef AQS_CONTACT_OBSTACLE_CONTACT_TERM_H_
#define AQS_CONTACT_OBSTACLE_CONTACT_TERM_H_

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

}  // namespace aqs

#endif  // AQS_CONTACT_OBSTACLE_CONTACT_TERM_H_
