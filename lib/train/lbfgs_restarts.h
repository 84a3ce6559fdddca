#ifndef AQS_TRAIN_LBFGS_RESTARTS_H_
#define AQS_TRAIN_LBFGS_RESTARTS_H_

#include <ostream>
#include <string>
#include <vector>

#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>
#include <ceres/iteration_callback.h>

namespace aqs {

// L-BFGS runs (Ceres' GradientProblemSolver) that restart where the line search stalls:
// the one rule by which end-to-end training, pre-training and the evaluation's
// auto-encoder baseline spend their iteration budgets.

// Whether a solve that ended with `summary` stalled before its budget: Ceres'
// CONVERGENCE (a tolerance met: on a loss only as smooth as its round-off, or its
// equilibria, the function tolerance is met far from a minimum) or FAILURE (the line
// search found no valid step size).
bool LbfgsStalled(const ceres::GradientProblemSolver::Summary& summary);

// What a caller with more to do between solves than restarting may add (end-to-end
// training: its latent refits, time budget and pose equilibria). Every hook has a
// default that does nothing.
class LbfgsSolveHooks {
 public:
  virtual ~LbfgsSolveHooks() = default;
  // Before each solve, with `done` iterations done and the point reached in
  // `parameters` (which the hook may change): the iteration count in all that this
  // solve may reach, in (done, max_iterations] (less than max_iterations: the solve
  // ends there without stalling, and the next one follows without counting as a
  // restart). Default: max_iterations.
  virtual int BeforeSolve(int done, int max_iterations, double* parameters) {
    return max_iterations;
  }
  // After each solve that ended with `summary`, `done` iterations done in all:
  // false to stop here (a time budget). *termination (Ceres' message) may be
  // completed. Default: true.
  virtual bool AfterSolve(const ceres::GradientProblemSolver::Summary& summary, int done,
                          std::string* termination) {
    return true;
  }
  // Before a restart from `parameters`, the last accepted point. Default: nothing.
  virtual void BeforeRestart(const double* parameters) {}
  // At the start point of each solve (Ceres' iteration 0, after its evaluation), in
  // `parameters`: the run's start, a restart's accepted point, or the point BeforeSolve
  // left (end-to-end training: the refitted latents, whose equilibria it keeps here).
  // Called before the numbered callbacks. Default: nothing.
  virtual void AtSolveStart(const double* parameters) {}
};

struct LbfgsRestartOptions {
  // Iterations in all, counting the `done` of RunLbfgsWithRestarts.
  int max_iterations = 0;
  // Restarts allowed after a stall (TrainOptions::max_restarts' default).
  int max_restarts = 50;
  // Called at every iteration as if the run were one uninterrupted solve: their
  // IterationSummary::iteration counts from the start of this run (0: its start
  // point), each iteration once (a restart's first iteration, the accepted point again,
  // is not repeated; the iteration that ends a solve by a convergence test, on which
  // Ceres runs no callback, is passed on after the solve, with *parameters at it).
  // Where a callback stops the solver (anything but SOLVER_CONTINUE), the run ends.
  // Callbacks in the solver options' own list see each solve as Ceres runs it
  // (iteration 0 at every restart; no call on an iteration that meets a convergence
  // test).
  std::vector<ceres::IterationCallback*> callbacks;
};

struct LbfgsRunReport {
  int iterations = 0;  // in all after the run (`done` included)
  int restarts = 0;    // restarts after a stall
  // The last solve's: Ceres' termination type and message (as completed by
  // LbfgsSolveHooks::AfterSolve).
  ceres::TerminationType termination_type = ceres::NO_CONVERGENCE;
  std::string termination;
  // The first solve could not evaluate its start with the gradient (Ceres records no
  // iteration 0 then): nothing was done, and no restart can do better.
  bool start_failed = false;
};

// Ceres' L-BFGS (solver_options, with max_num_iterations set per solve) on `problem`
// from *parameters, `done` iterations done before, until options.max_iterations are
// done: where a solve stalls (LbfgsStalled) before that, L-BFGS restarts from the last
// accepted point with an empty memory (a steepest-descent step first), saying
//   "  L-BFGS stopped (<Ceres' message>); restarting from iteration <done>"
// in `log`, up to options.max_restarts times and as long as each solve makes a step.
// The run also ends where a callback stops the solver, or where hooks->AfterSolve says
// so. *parameters always ends at the last accepted point: the solver updates it every
// iteration (update_state_every_iteration is set), since Ceres does not copy its
// solution back after a FAILURE. `hooks` may be null. Requires done <
// options.max_iterations and max_restarts >= 0 (CHECKs).
LbfgsRunReport RunLbfgsWithRestarts(ceres::GradientProblemSolver::Options solver_options,
                                    const ceres::GradientProblem& problem,
                                    const LbfgsRestartOptions& options, int done,
                                    double* parameters, std::ostream& log,
                                    LbfgsSolveHooks* hooks = nullptr);

}  // namespace aqs

#endif  // AQS_TRAIN_LBFGS_RESTARTS_H_
