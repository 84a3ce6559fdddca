#ifndef AQS_FIT_LATENT_PRIOR_H_
#define AQS_FIT_LATENT_PRIOR_H_

#include <ceres/cost_function.h>

namespace aqs {

// The latent prior lambda |z|^2 as Ceres residuals r = sqrt(lambda) z over one
// parameter block z of size d; Jacobian sqrt(lambda) I (d x d, row-major).
class LatentPrior final : public ceres::CostFunction {
 public:
  LatentPrior(int d, double lambda);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  int d_;
  double scale_;
};

}  // namespace aqs

#endif  // AQS_FIT_LATENT_PRIOR_H_
