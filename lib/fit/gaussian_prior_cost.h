#ifndef AQS_FIT_GAUSSIAN_PRIOR_COST_H_
#define AQS_FIT_GAUSSIAN_PRIOR_COST_H_

#include <ceres/cost_function.h>
#include <Eigen/Core>

namespace aqs {

// A Gaussian prior as Ceres residuals over one parameter block x of size n:
//   r = sqrt(weight) W (x - mean)      (n residuals),
// W the prior's whitening (n x n, W^T W = covariance^-1), so |r|^2 is weight times the
// squared Mahalanobis distance. Jacobian dr/dx = sqrt(weight) W (n x n, row-major).
class GaussianPriorCost final : public ceres::CostFunction {
 public:
  GaussianPriorCost(const Eigen::VectorXd& mean, const Eigen::MatrixXd& whitening, double weight);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::VectorXd mean_;
  Eigen::MatrixXd scaled_whitening_;  // sqrt(weight) W
};

}  // namespace aqs

#endif  // AQS_FIT_GAUSSIAN_PRIOR_COST_H_
