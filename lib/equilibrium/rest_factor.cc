#include "equilibrium/rest_factor.h"

#include <string>

namespace aqs {

StoredStiffnessFactor RestStiffnessFactor(const Eigen::Matrix3Xd& rest,
                                          QuasistaticSolver* solver) {
  StoredStiffnessFactor stored;
  StiffnessFactorization* factorization = solver->stiffness_factorization();
  std::string error;
  if (factorization->Factorize(rest, solver->actuation(), StiffnessKind::kExact, &error)) {
    factorization->StoreFactor(&stored);
  }
  return stored;
}

void StartFromFactor(const StoredStiffnessFactor& stored, QuasistaticSolver* solver) {
  StiffnessFactorization* factorization = solver->stiffness_factorization();
  if (stored.empty() || !factorization->RestoreFactor(stored)) factorization->RequestRefresh();
}

}  // namespace aqs
