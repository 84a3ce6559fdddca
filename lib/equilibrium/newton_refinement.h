#ifndef AQS_EQUILIBRIUM_NEWTON_REFINEMENT_H_
#define AQS_EQUILIBRIUM_NEWTON_REFINEMENT_H_

#include <string>

#include <Eigen/Core>

#include "equilibrium/stiffness_factorization.h"
#include "physics/actuation.h"

namespace aqs {

struct NewtonRefinementOptions {
  // Stop when the largest free-vertex force |dE/dx_v| is at most this (absolute).
  double force_tolerance = 0.0;
  int max_steps = 5;
  // Step halvings tried when a full Newton step does not reduce the largest force.
  int max_halvings = 4;
};

struct NewtonRefinementReport {
  bool converged = false;
  int steps = 0;  // factorizations done
  double initial_max_force = 0.0;
  double final_max_force = 0.0;
  double final_energy = 0.0;
  std::string message;
};

// Newton's method with the exact stiffness from a near-equilibrium state x
// (3 x num_vertices; fixed vertices already at their positions, which are kept):
// x <- x - t K(x)^-1 dE/dx on free DOFs, t = 1 unless halving is needed to reduce the
// largest force. Near an equilibrium this converges quadratically, where
// Gauss-Newton/Levenberg-Marquardt on the least-squares form converges only linearly
// (its J^T J lacks the curvature of incompatible targets). And since the force is
// computable to round-off, it reaches forces near 1e-14 of the model's force scale,
// below the floor of energy-decrease tests (see QuasistaticSolverOptions).
//
// Stops with converged = false and a message if K is not positive definite (x is not
// near a stable equilibrium) or the force stops decreasing. `factorization` is built
// for the model and fixed vertices of x.
NewtonRefinementReport RefineEquilibrium(const NewtonRefinementOptions& options,
                                         const ShapeTargetModel::ActuationRef& a,
                                         StiffnessFactorization* factorization,
                                         Eigen::Matrix3Xd* x);

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_NEWTON_REFINEMENT_H_
