#include "fit/gaussian_prior_cost.h"

#include <cmath>

#include <glog/logging.h>

namespace aqs {

GaussianPriorCost::GaussianPriorCost(const Eigen::VectorXd& mean, const Eigen::MatrixXd& whitening,
                                     double weight)
    : mean_(mean), scaled_whitening_(std::sqrt(weight) * whitening) {
  CHECK_GE(weight, 0.0);
  CHECK_EQ(whitening.rows(), mean.size());
  CHECK_EQ(whitening.cols(), mean.size());
  set_num_residuals(static_cast<int>(mean.size()));
  mutable_parameter_block_sizes()->push_back(static_cast<int>(mean.size()));
}

bool GaussianPriorCost::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const Eigen::Index n = mean_.size();
  const Eigen::Map<const Eigen::VectorXd> x(parameters[0], n);
  Eigen::Map<Eigen::VectorXd>(residuals, n) = scaled_whitening_ * (x - mean_);
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        jacobians[0], n, n) = scaled_whitening_;
  }
  return true;
}

}  // namespace aqs
