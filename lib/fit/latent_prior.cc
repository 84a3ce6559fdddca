#include "fit/latent_prior.h"

#include <cmath>

#include <Eigen/Core>

namespace aqs {

LatentPrior::LatentPrior(int d, double lambda) : d_(d), scale_(std::sqrt(lambda)) {
  set_num_residuals(d);
  mutable_parameter_block_sizes()->push_back(d);
}

bool LatentPrior::Evaluate(double const* const* parameters, double* residuals,
                           double** jacobians) const {
  for (int i = 0; i < d_; ++i) residuals[i] = scale_ * parameters[0][i];
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        jacobians[0], d_, d_) = scale_ * Eigen::MatrixXd::Identity(d_, d_);
  }
  return true;
}

}  // namespace aqs
