#ifndef AQS_TESTING_GRADIENT_CHECK_H_
#define AQS_TESTING_GRADIENT_CHECK_H_

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/numeric_diff_options.h>

namespace aqs {
namespace testing {

// Numeric differentiation options for Ceres' GradientChecker: Ridders' method from a
// relative initial step of `relative_step` (Ceres' default 1e-2 jumps across kinks and
// distorts small features; start at a step the state resolves).
ceres::NumericDiffOptions RiddersFrom(double relative_step);

// Ceres' GradientChecker on `cost` (no manifolds) at `parameters` (one pointer per
// parameter block), into *results; returns its verdict at relative `precision`
// (GradientChecker::Probe).
bool ProbeJacobians(const ceres::CostFunction& cost, const double* const* parameters,
                    double precision, ceres::GradientChecker::ProbeResults* results,
                    const ceres::NumericDiffOptions& numeric = ceres::NumericDiffOptions());

// The largest RelativeError(analytic, numeric, floor) (finite_difference.h) over the
// parameter blocks of a probe.
double MaxBlockError(const ceres::GradientChecker::ProbeResults& results, double floor);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_GRADIENT_CHECK_H_
