#ifndef AQS_EQUILIBRIUM_PRECONDITIONED_LBFGS_H_
#define AQS_EQUILIBRIUM_PRECONDITIONED_LBFGS_H_

#include <string>

#include <Eigen/Core>

#include "equilibrium/line_search.h"
#include "equilibrium/stiffness_factorization.h"
#include "physics/actuation.h"

namespace aqs {

struct PreconditionedLbfgsOptions {
  // Stop once the largest free-vertex force |dE/dx_v| is at most this (absolute).
  double force_tolerance = 0.0;
  int max_iterations = 500;
  // Stalls: stop once the largest force has not fallen to stall_reduction x its value at
  // the last mark in stall_iterations accepted steps (a mark is set at the start and
  // wherever the force reaches that fraction). With a preconditioner that fits the state
  // (an exact stiffness nearby) each halving takes a few steps; tens mean it no longer
  // fits, and Newton would converge faster. Not for rotation-dominated motion from rest:
  // there the force rises and falls while the body swings (tests/equilibrium). 0: no
  // stall test.
  int stall_iterations = 0;
  double stall_reduction = 0.5;
  // Correction pairs kept (L-BFGS memory).
  int memory = 10;
  ArmijoLineSearch line_search;

  // Checks the fields; false with *error naming the field.
  bool Validate(std::string* error) const;
};

struct PreconditionedLbfgsReport {
  bool converged = false;  // the force tolerance was reached
  bool stalled = false;    // stopped by the stall test (options.stall_iterations)
  int iterations = 0;      // accepted steps (one preconditioner solve each)
  int energy_evaluations = 0;
  int memory_resets = 0;  // directions that did not descend, replaced by M^-1 g
  // Accepted steps whose correction pair (s, y) had no positive curvature (s . y <= 1e-12
  // |s| |y|, where the energy is concave along the step): not kept in the memory, whose
  // inverse Hessian would be indefinite with them.
  int skipped_pairs = 0;
  double initial_energy = 0.0, final_energy = 0.0;
  double initial_max_force = 0.0, final_max_force = 0.0;
  std::string message;
};

// Minimizes the total energy E(x, a) (+ the energy terms of `preconditioner`) over the
// free vertices of x (3 x num_vertices; fixed vertices at their positions are kept) by
// L-BFGS whose initial inverse Hessian is M^-1, with M the stiffness `preconditioner`
// holds factorized, and a backtracking Armijo line search from the unit step.
//
// With M the rotation-fixed stiffness (StiffnessKind::kRotationFixed: the Hessian of E
// with every element's rotation held, constant in x and a), the first step is a
// projective-dynamics (local/global) step, and the correction pairs add the curvature
// the rotations carry. Each iteration costs one solve with M and one energy
// evaluation, no factorization: far from equilibrium, where a Newton step is limited
// by the linearized rotations, this descends for a fraction of the cost (Liu, Bouaziz
// and Kavan, "Quasi-Newton methods for real-time simulation of hyperelastic materials",
// 2017). Near equilibrium it converges linearly: MinimizeEnergyNewton finishes.
//
// Stops at the force tolerance, at max_iterations, at a stall (see
// PreconditionedLbfgsOptions::stall_iterations), or when the line search fails even on
// the preconditioned gradient (message says which); x then holds the best state.
// CHECKs options.Validate() (a programmer error: the solver builds valid options).
PreconditionedLbfgsReport MinimizeEnergyLbfgs(const PreconditionedLbfgsOptions& options,
                                              const ShapeTargetModel::ActuationRef& a,
                                              StiffnessFactorization* preconditioner,
                                              Eigen::Matrix3Xd* x);

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_PRECONDITIONED_LBFGS_H_
