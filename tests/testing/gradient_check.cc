#include "testing/gradient_check.h"

#include <algorithm>
#include <vector>

#include <ceres/manifold.h>

#include "testing/finite_difference.h"

namespace aqs {
namespace testing {

ceres::NumericDiffOptions RiddersFrom(double relative_step) {
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = relative_step;
  return numeric;
}

bool ProbeJacobians(const ceres::CostFunction& cost, const double* const* parameters,
                    double precision, ceres::GradientChecker::ProbeResults* results,
                    const ceres::NumericDiffOptions& numeric) {
  const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
  const ceres::GradientChecker checker(&cost, no_manifolds, numeric);
  return checker.Probe(parameters, precision, results);
}

double MaxBlockError(const ceres::GradientChecker::ProbeResults& results, double floor) {
  double worst = 0;
  for (size_t b = 0; b < results.jacobians.size(); ++b) {
    worst = std::max(worst, RelativeError(results.jacobians[b], results.numeric_jacobians[b], floor));
  }
  return worst;
}

}  // namespace testing
}  // namespace aqs
