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
  double solve_seconds = 0;    // equilibria (summed over poses: thread time)
  double adjoint_seconds = 0;  // adjoint solves and dL/da (thread time)
  double decoder_seconds = 0;  // decoding and back-propagation (wall)
  double seconds = 0;          // whole evaluations (wall)

  // These counters minus `before` (an earlier reading of the same totals).
  EvaluationCounters Since(const EvaluationCounters& before) const {
    EvaluationCounters d = *this;
    d.evaluations -= before.evaluations;
    d.factorizations -= before.factorizations;
    d.adjoint_factorizations -= before.adjoint_factorizations;
    d.reused_solves -= before.reused_solves;
    d.cg_iterations -= before.cg_iterations;
    d.lbfgs_iterations -= before.lbfgs_iterations;
    d.newton_steps -= before.newton_steps;
    d.retries_from_rest -= before.retries_from_rest;
    d.solve_seconds -= before.solve_seconds;
    d.adjoint_seconds -= before.adjoint_seconds;
    d.decoder_seconds -= before.decoder_seconds;
    d.seconds -= before.seconds;
    return d;
  }

  void Add(const EvaluationCounters& other) {
    evaluations += other.evaluations;
    factorizations += other.factorizations;
    adjoint_factorizations += other.adjoint_factorizations;
    reused_solves += other.reused_solves;
    cg_iterations += other.cg_iterations;
    lbfgs_iterations += other.lbfgs_iterations;
    newton_steps += other.newton_steps;
    retries_from_rest += other.retries_from_rest;
    solve_seconds += other.solve_seconds;
    adjoint_seconds += other.adjoint_seconds;
    decoder_seconds += other.decoder_seconds;
    seconds += other.seconds;
  }
};

}  // namespace aqs

#endif  // AQS_TRAIN_EVALUATION_COUNTERS_H_
