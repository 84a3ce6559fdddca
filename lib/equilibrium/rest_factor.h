#ifndef AQS_EQUILIBRIUM_REST_FACTOR_H_
#define AQS_EQUILIBRIUM_REST_FACTOR_H_

#include <Eigen/Core>

#include "equilibrium/quasistatic_solver.h"
#include "equilibrium/stiffness_factorization.h"

namespace aqs {

// The exact stiffness of the body under the solver's current actuation (its energy terms
// included) at the positions `rest` (3 x num_vertices), factorized by the solver's
// stiffness factorization and kept in single precision. Empty if it does not factorize.
//
// A solver shared by several poses in turn restores it before each pose
// (StartFromFactor): every pose's solve then starts from the same factor, not from the
// one the previous pose left, so that its result depends on nothing but the pose, not on
// which thread or rank solved it or in what order.
StoredStiffnessFactor RestStiffnessFactor(const Eigen::Matrix3Xd& rest,
                                          QuasistaticSolver* solver);

// Makes `stored` the factor the solver's next solve starts from; where it cannot (empty,
// or of another analysis), the next solve factorizes afresh instead of reusing the factor
// held now.
void StartFromFactor(const StoredStiffnessFactor& stored, QuasistaticSolver* solver);

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_REST_FACTOR_H_
