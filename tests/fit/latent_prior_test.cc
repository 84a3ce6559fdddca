#include "fit/latent_prior.h"

#include <cmath>
#include <vector>

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

namespace aqs {
namespace {

// r = sqrt(lambda) z with its Jacobian, against Ceres' numeric differentiation.
TEST(LatentPriorTest, ResidualsAndGradientChecker) {
  const int d = 5;
  const double lambda = 0.3;
  LatentPrior prior(d, lambda);
  std::vector<double> z = {0.7, -1.2, 0.05, 3.0, -0.4};
  const double* parameters[] = {z.data()};
  std::vector<double> residuals(d);
  ASSERT_TRUE(prior.Evaluate(parameters, residuals.data(), nullptr));
  for (int i = 0; i < d; ++i) EXPECT_DOUBLE_EQ(residuals[i], std::sqrt(lambda) * z[i]);
  ceres::NumericDiffOptions numeric_options;
  const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
  ceres::GradientChecker checker(&prior, no_manifolds, numeric_options);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(parameters, 1e-9, &results)) << results.error_log;
}

}  // namespace
}  // namespace aqs
