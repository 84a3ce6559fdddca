#ifndef AQS_TESTING_ENERGY_TERM_CHECKS_H_
#define AQS_TESTING_ENERGY_TERM_CHECKS_H_

#include <Eigen/Core>

#include "equilibrium/energy_term.h"

namespace aqs {
namespace testing {

// A term's stiffness of `kind` at x (3 x n, all vertices free) as a dense 3n x 3n
// matrix, on the pattern of the given elements plus the term's couplings.
Eigen::MatrixXd DenseStiffness(const EnergyTerm& term, const Eigen::Matrix3Xd& x,
                               const Eigen::Matrix4Xi& tets,
                               StiffnessKind kind = StiffnessKind::kExact);

// Central differences of a term's energy gradient at x (3 x n): its Hessian, 3n x 3n.
Eigen::MatrixXd DifferencedHessian(const EnergyTerm& term, const Eigen::Matrix3Xd& x);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_ENERGY_TERM_CHECKS_H_
