#ifndef AQS_EQUILIBRIUM_NEWTON_SOLVER_H_
#define AQS_EQUILIBRIUM_NEWTON_SOLVER_H_

#include <limits>
#include <string>

#include <Eigen/Core>

#include "equilibrium/line_search.h"
#include "equilibrium/stiffness_factorization.h"
#include "physics/actuation.h"

namespace aqs {

struct NewtonSolverOptions {
  // Stop when the largest free-vertex force |dE/dx_v| is at most this (absolute).
  double force_tolerance = 0.0;
  // Steps use the exact stiffness once the largest force is at most this (absolute);
  // above it, the PSD-projected one. infinity: exact from the start (a refinement of a
  // state already near a stable equilibrium); 0: projected only.
  double exact_force_threshold = std::numeric_limits<double>::infinity();
  // Factorizations at most (each step factorizes once; a step whose exact stiffness is
  // not positive definite, or needs a diagonal shift, factorizes again).
  int max_factorizations = 100;
  // Exact steps by CG on an earlier factor (reuse), which cost no factorization, are
  // tried at most this many times; later exact steps factorize, so that the solve ends
  // within max_factorizations. (At the energy's round-off floor such steps can be
  // accepted without end, the force wavering in its last digits.)
  int max_reused_steps = 100;
  // The solve stops, not converged (NewtonSolveReport::stalled), after this many accepted
  // steps that backtracked (step length below 1) since the last step that made progress:
  // that lowered the energy by more than 1e-10 of its value then, or the largest force
  // below 0.9 of its value then. A full step is progress too (a saddle's escape by
  // projected steps, a projected crawl); a step along negative curvature is judged by
  // the energy and force alone. Where the energy has a kink, the
  // force cannot fall below the gradient's jump and the line search accepts ever shorter
  // steps at the energy's round-off; this stops that. 0: never (the budget alone ends
  // such a solve; at the round-off floor max_reused_steps then decides).
  int stall_steps = 16;  // QuasistaticSolverOptions::kDefaultNewtonStallSteps
  // Where the exact K is still indefinite on a retry, a step along its direction of most
  // negative curvature (found with the projected factor; see negative_curvature.h)
  // replaces the projected step: it leaves a saddle that projected steps leave only
  // slowly. false (the default, see QuasistaticSolverOptions): projected steps only.
  bool negative_curvature_steps = false;
  // The solve stops, not converged (NewtonSolveReport::handed_back), after this many
  // accepted projected steps: for a caller that then descends by a cheaper method
  // (QuasistaticSolver's preconditioned L-BFGS, one factorization per solve instead of
  // one per step) to a smaller force and comes back. Where the exact K is indefinite
  // well below the handover force, projected steps crawl, one factorization each (a
  // bar curled at 0.99: 36 of them; the demo face's jaw pushed back: 64). 0: never.
  int hand_back_after_projected_steps = 0;
  ArmijoLineSearch line_search;
  // Exact steps first try conjugate gradients on the current stiffness preconditioned by
  // the factor the factorization holds from an earlier state (a warm start's, the last
  // step's), with no factorization (an inexact Newton step); max_iterations = 0 disables.
  FactorReuseOptions reuse = {20, 1e-6, 6, 1e-2, 1, 8};

  // Checks the fields; false with *error naming the field.
  bool Validate(std::string* error) const;
};

struct NewtonSolveReport {
  bool converged = false;
  int projected_steps = 0;  // accepted steps on the PSD-projected stiffness
  int exact_steps = 0;      // accepted steps on the exact stiffness
  int reused_steps = 0;     // of those, solved by CG on an earlier factor (no factorization)
  int factorizations = 0;   // CHOLMOD numeric factorizations, all kinds
  int shifted_factorizations = 0;  // of those, with a diagonal shift (singular K)
  int negative_curvature_steps = 0;  // accepted steps along a direction where K curves down
  // Exact stiffness not positive definite (found by its factorization, or by CG without
  // one), or its step failed.
  int exact_rejections = 0;
  int energy_evaluations = 0;  // line-search trials
  // Stopped by the stall rule (NewtonSolverOptions::stall_steps).
  bool stalled = false;
  // Stopped after NewtonSolverOptions::hand_back_after_projected_steps projected steps.
  bool handed_back = false;
  double initial_energy = 0.0, final_energy = 0.0;
  double initial_max_force = 0.0, final_max_force = 0.0;
  std::string message;  // why the solve stopped
};

// Minimizes the total energy E(x, a) (+ the factorization's energy terms) over the free
// vertices of x (3 x num_vertices; fixed vertices are at their positions and are kept)
// by Newton's method with a backtracking line search:
//
//   d = -K(x)^-1 dE/dx,   x <- x + t d,   t = 1, 1/2, 1/4, ... until
//   E(x + t d) <= E(x) + armijo t dE/dx . d   (sufficient decrease), or, where that test
//   is below the round-off of E, until the largest force decreases.
//
// Far from equilibrium (largest force above exact_force_threshold) K is the
// PSD-projected stiffness (per-element eigenvalue clamp of dP/dF, Gauss-Newton parts of
// the energy terms): every step descends, from any start. Near it K is the exact
// stiffness, which converges quadratically; where the exact K is not positive definite,
// or its step does not descend, the step is taken on the projected K instead (when CG
// on an earlier factor has already met non-positive curvature of the exact K, that K is
// rejected without factorizing it); exact steps are tried again once the force has
// halved, or after 4 projected steps. Where such a retry finds the exact K still
// indefinite, the step goes along K's most negative curvature instead (with
// negative_curvature_steps): near a saddle, where the force is small but K indefinite,
// projected steps leave only slowly and exact steps by CG can converge to the saddle.
// A singular projected K (e.g. elements with no resisting mode) is shifted by a multiple
// of its mean diagonal, growing until CHOLMOD succeeds.
//
// Returns with converged = true once the largest force is at most force_tolerance; it
// also stops, not converged (stalled = true), by the stall rule (options.stall_steps). The
// factorization (built for the model, fixed vertices and energy terms of x) is left
// holding the last factorized stiffness. options must be valid (Validate; CHECKed: the
// library builds them, from validated QuasistaticSolverOptions).
NewtonSolveReport MinimizeEnergyNewton(const NewtonSolverOptions& options,
                                       const ShapeTargetModel::ActuationRef& a,
                                       StiffnessFactorization* factorization,
                                       Eigen::Matrix3Xd* x);

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_NEWTON_SOLVER_H_
