#ifndef AQS_TESTING_FINITE_DIFFERENCE_H_
#define AQS_TESTING_FINITE_DIFFERENCE_H_

#include <functional>

#include <Eigen/Core>
#include <gtest/gtest.h>

namespace aqs {
namespace testing {

// Central-difference Jacobian of f: R^n -> R^m at x, 4th order (Richardson-style
// five-point stencil) with step h (per coordinate, absolute). Returns m x n.
Eigen::MatrixXd CentralDifferenceJacobian(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
    const Eigen::VectorXd& x, double h);

// Central-difference gradient of a scalar f at x (n-vector), same stencil.
Eigen::VectorXd CentralDifferenceGradient(
    const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x,
    double h);

// Directional derivative of f along v: (f(x + h v) - f(x - h v)) / 2h, 4th order.
Eigen::VectorXd CentralDifferenceDirectional(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
    const Eigen::VectorXd& x, const Eigen::VectorXd& v, double h);

// max |a - b| / max(max |b|, floor): the error measure every derivative test uses.
double RelativeError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double floor = 1e-12);

// Success if `hessian` (n x n) is symmetric (|H - H^T| <= 1e-12 |H|, Frobenius) and its
// RelativeError against the central-difference Jacobian (step h) of `gradient` at x
// (n-vector) is below `tolerance`; the failure gives both.
::testing::AssertionResult SymmetricHessianMatchesGradient(
    const Eigen::MatrixXd& hessian,
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& gradient,
    const Eigen::VectorXd& x, double h, double tolerance);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_FINITE_DIFFERENCE_H_
