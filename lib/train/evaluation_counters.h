#ifndef AQS_TRAIN_EVALUATION_COUNTERS_H_
#define AQS_TRAIN_EVALUATION_COUNTERS_H_

namespace aqs {

// What evaluations of the end-to-end training objective cost, summed over poses (and,
// for totals, over evaluations).
struct EvaluationCounters {
  int evaluations = 0;
  int factorizations = 0;          // stiffness factorizations, all kinds
  int adjoint_factorizations = 0;  // of those, done for an adjoint
  int reused_solves = 0;  // Newton steps and adjoints solved by CG on an earlier factor
  int cg_iterations = 0;
  int lbfgs_iterations = 0;  // the solver's L-BFGS, far from equilibrium
  int newton_steps = 0;
  int retries_from_rest = 0;
  int unstable_escapes = 0;  // unstable equilibria left by a perturbation and a new solve
  int shifted_adjoints = 0;  // adjoints of a shifted K (K not positive definite even then)
  int line_starts = 0;  // solves started on a line search's line (TrainOptions::line_search_starts)
  double solve_seconds = 0;    // equilibria (summed over poses: thread time)
  double adjoint_seconds = 0;  // adjoint solves and dL/da (thread time)
  double decoder_seconds = 0;  // decoding and back-propagation (wall)
  double seconds = 0;          // whole evaluations (wall)

  // These counters minus `before` (an earlier reading of the same totals).
  EvaluationCounters Since(const EvaluationCounters& before) const {
    EvaluationCounters d = *this;
    d.Add(before, -1);
    return d;
  }

  // Adds sign x other, field by field.
  void Add(const EvaluationCounters& other, int sign = 1) {
    evaluations += sign * other.evaluations;
    factorizations += sign * other.factorizations;
    adjoint_factorizations += sign * other.adjoint_factorizations;
    reused_solves += sign * other.reused_solves;
    cg_iterations += sign * other.cg_iterations;
    lbfgs_iterations += sign * other.lbfgs_iterations;
    newton_steps += sign * other.newton_steps;
    retries_from_rest += sign * other.retries_from_rest;
    unstable_escapes += sign * other.unstable_escapes;
    shifted_adjoints += sign * other.shifted_adjoints;
    line_starts += sign * other.line_starts;
    solve_seconds += sign * other.solve_seconds;
    adjoint_seconds += sign * other.adjoint_seconds;
    decoder_seconds += sign * other.decoder_seconds;
    seconds += sign * other.seconds;
  }
};

}  // namespace aqs

#endif  // AQS_TRAIN_EVALUATION_COUNTERS_H_
