#ifndef AQS_DIFF_NEWTON_REFINEMENT_H_
#define AQS_DIFF_NEWTON_REFINEMENT_H_

#include <string>

#include <Eigen/Core>

#include "diff/equilibrium_differentiator.h"
#include "physics/actuation.h"

namespace aqs {

struct NewtonRefinementOptions {
  // Stop when the largest free-vertex force |dE/dx_v| is at most this (absolute).
  double force_tolerance = 0.0;
  int max_steps = 5;
  // Step halvings tried when a full Newton step does not reduce the largest force.
  int max_halvings = 6;
};

struct NewtonRefinementReport {
  bool converged = false;
  int steps = 0;
  double initial_max_force = 0.0;
  double final_max_force = 0.0;
  std::string message;
};

// Refines a near-equilibrium state x (3 x num_vertices, fixed vertices already at
// their positions, which are kept) with Newton steps using the exact stiffness:
// x <- x - t K(x)^-1 dE/dx on free DOFs, t = 1 unless halving is needed to reduce the
// largest force. Unlike an energy-decrease test, the force is computable to round-off,
// so this reaches forces near 1e-14 of the model's force scale where least-squares
// solvers stall at ~1e-9 (see QuasistaticSolverOptions). Quadratic convergence needs a
// start inside Newton's basin, e.g. a QuasistaticSolver result.
//
// Uses (and leaves prepared at the last factorized state) `differentiator`, built for
// the same model and fixed vertices. Stops with converged = false and a message if K
// is not positive definite or the force stops decreasing.
NewtonRefinementReport RefineEquilibrium(const NewtonRefinementOptions& options,
                                         const ActuationMatrix& a,
                                         EquilibriumDifferentiator* differentiator,
                                         Eigen::Matrix3Xd* x);

}  // namespace aqs

#endif  // AQS_DIFF_NEWTON_REFINEMENT_H_
