#include "testing/finite_difference.h"

#include <algorithm>

namespace aqs {
namespace testing {

Eigen::VectorXd CentralDifferenceDirectional(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
    const Eigen::VectorXd& x, const Eigen::VectorXd& v, double h) {
  const Eigen::VectorXd f1p = f(x + h * v);
  const Eigen::VectorXd f1m = f(x - h * v);
  const Eigen::VectorXd f2p = f(x + 2 * h * v);
  const Eigen::VectorXd f2m = f(x - 2 * h * v);
  return (8.0 * (f1p - f1m) - (f2p - f2m)) / (12.0 * h);
}

Eigen::MatrixXd CentralDifferenceJacobian(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
    const Eigen::VectorXd& x, double h) {
  const Eigen::Index n = x.size();
  Eigen::MatrixXd jacobian;
  for (Eigen::Index j = 0; j < n; ++j) {
    const Eigen::VectorXd column =
        CentralDifferenceDirectional(f, x, Eigen::VectorXd::Unit(n, j), h);
    if (j == 0) jacobian.resize(column.size(), n);
    jacobian.col(j) = column;
  }
  return jacobian;
}

Eigen::VectorXd CentralDifferenceGradient(
    const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x,
    double h) {
  auto as_vector = [&f](const Eigen::VectorXd& y) {
    return Eigen::VectorXd::Constant(1, f(y));
  };
  return CentralDifferenceJacobian(as_vector, x, h).transpose();
}

double RelativeError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double floor) {
  const double scale = std::max(b.cwiseAbs().maxCoeff(), floor);
  return (a - b).cwiseAbs().maxCoeff() / scale;
}

::testing::AssertionResult SymmetricHessianMatchesGradient(
    const Eigen::MatrixXd& hessian,
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& gradient,
    const Eigen::VectorXd& x, double h, double tolerance) {
  const double error = RelativeError(hessian, CentralDifferenceJacobian(gradient, x, h));
  const double asymmetry = (hessian - hessian.transpose()).norm();
  if (error < tolerance && asymmetry <= 1e-12 * hessian.norm()) {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure()
         << "Hessian against differenced gradient: relative error " << error << " (tolerance "
         << tolerance << "), |H - H^T| " << asymmetry << " against |H| " << hessian.norm();
}

}  // namespace testing
}  // namespace aqs
