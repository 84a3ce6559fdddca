#include "fit/gaussian_prior_cost.h"

#include <vector>

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

namespace aqs {
namespace {

// r = sqrt(weight) W (x - mean) and its Jacobian, against Ceres' numeric differentiation.
TEST(GaussianPriorCostTest, ResidualsAndGradientChecker) {
  const int n = 4;
  Eigen::VectorXd mean(n);
  mean << 0.3, -1.0, 2.0, 0.01;
  Eigen::MatrixXd w = Eigen::MatrixXd::Random(n, n);
  w.diagonal().array() += 3.0;
  const double weight = 0.7;
  GaussianPriorCost cost(mean, w, weight);
  std::vector<double> x = {0.5, 0.2, -1.5, 4.0};
  const double* parameters[] = {x.data()};
  Eigen::VectorXd residuals(n);
  ASSERT_TRUE(cost.Evaluate(parameters, residuals.data(), nullptr));
  const Eigen::VectorXd expected =
      std::sqrt(weight) * w * (Eigen::Map<const Eigen::VectorXd>(x.data(), n) - mean);
  EXPECT_LT((residuals - expected).norm(), 1e-14);
  ceres::NumericDiffOptions numeric_options;
  const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
  ceres::GradientChecker checker(&cost, no_manifolds, numeric_options);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(parameters, 1e-9, &results)) << results.error_log;
}

}  // namespace
}  // namespace aqs
