#include "testing/energy_term_checks.h"

#include <vector>

#include "sparse/stiffness_pattern.h"
#include "testing/finite_difference.h"

namespace aqs {
namespace testing {

Eigen::MatrixXd DenseStiffness(const EnergyTerm& term, const Eigen::Matrix3Xd& x,
                               const Eigen::Matrix4Xi& tets, StiffnessKind kind) {
  const int n = static_cast<int>(x.cols());
  std::vector<std::vector<int>> couplings;
  term.AppendVertexCouplings(&couplings);
  const StiffnessPattern pattern(tets, std::vector<bool>(n, false), couplings);
  std::vector<double> values(pattern.num_nonzeros(), 0.0);
  term.AddStiffness(x, pattern, kind, &values);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (int j = 0; j < pattern.num_dofs(); ++j) {
    for (int64_t k = pattern.column_starts()[j]; k < pattern.column_starts()[j + 1]; ++k) {
      const int64_t i = pattern.row_indices()[k];
      dense(i, j) = dense(j, i) = values[k];
    }
  }
  return dense;
}

Eigen::MatrixXd DifferencedHessian(const EnergyTerm& term, const Eigen::Matrix3Xd& x) {
  const int n = static_cast<int>(x.cols());
  auto gradient = [&](const Eigen::VectorXd& flat) {
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, n);
    term.AddEnergyAndGradient(Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, n), &g);
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(g.data(), 3 * n));
  };
  return CentralDifferenceJacobian(
      gradient, Eigen::Map<const Eigen::VectorXd>(x.data(), 3 * n), 1e-6);
}

}  // namespace testing
}  // namespace aqs
