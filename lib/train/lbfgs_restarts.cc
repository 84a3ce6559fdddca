#include "train/lbfgs_restarts.h"

#include <algorithm>
#include <utility>

#include <glog/logging.h>

namespace aqs {
namespace {

// Passes Ceres' iterations on to `callbacks` numbered from the start of the run, each
// once: the current solve's iteration k is iteration before + k of the run, and a later
// solve's iteration 0 (the point the previous solve ended at) is not passed on again.
class RunNumberedCallbacks final : public ceres::IterationCallback {
 public:
  explicit RunNumberedCallbacks(const std::vector<ceres::IterationCallback*>& callbacks)
      : callbacks_(callbacks) {}

  // A new solve starts after `before` iterations of the run.
  void StartSolve(int before) { before_ = before; }

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    if (before_ + summary.iteration <= last_) return ceres::SOLVER_CONTINUE;
    return PassOn(summary, before_ + summary.iteration);
  }

  // After a solve that ended with `summary`, `iterations` into the run: its last
  // iteration, if the callbacks have not seen it (Ceres runs no callback on the
  // iteration that meets a convergence test, though it counts it).
  ceres::CallbackReturnType PassOnLast(const ceres::GradientProblemSolver::Summary& summary,
                                       int iterations) {
    if (summary.iterations.empty() || iterations <= last_) return ceres::SOLVER_CONTINUE;
    return PassOn(summary.iterations.back(), iterations);
  }

 private:
  ceres::CallbackReturnType PassOn(const ceres::IterationSummary& summary, int iteration) {
    last_ = iteration;
    ceres::IterationSummary numbered = summary;
    numbered.iteration = iteration;
    for (ceres::IterationCallback* callback : callbacks_) {
      const ceres::CallbackReturnType status = (*callback)(numbered);
      if (status != ceres::SOLVER_CONTINUE) return status;
    }
    return ceres::SOLVER_CONTINUE;
  }

  const std::vector<ceres::IterationCallback*>& callbacks_;
  int before_ = 0;
  int last_ = -1;  // the last iteration passed on
};

// Calls LbfgsSolveHooks::AtSolveStart at iteration 0 of every solve.
class SolveStart final : public ceres::IterationCallback {
 public:
  SolveStart(LbfgsSolveHooks* hooks, const double* parameters)
      : hooks_(hooks), parameters_(parameters) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    if (summary.iteration == 0) hooks_->AtSolveStart(parameters_);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  LbfgsSolveHooks* hooks_;
  const double* parameters_;
};

}  // namespace

bool LbfgsStalled(const ceres::GradientProblemSolver::Summary& summary) {
  return summary.termination_type == ceres::CONVERGENCE ||
         summary.termination_type == ceres::FAILURE;
}

LbfgsRunReport RunLbfgsWithRestarts(ceres::GradientProblemSolver::Options solver_options,
                                    const ceres::GradientProblem& problem,
                                    const LbfgsRestartOptions& options, int done,
                                    double* parameters, std::ostream& log,
                                    LbfgsSolveHooks* hooks) {
  CHECK_LT(done, options.max_iterations);
  CHECK_GE(options.max_restarts, 0);
  LbfgsSolveHooks no_hooks;
  if (hooks == nullptr) hooks = &no_hooks;
  // The last accepted point must be in *parameters after every solve: a restart starts
  // there, and after a FAILURE Ceres does not copy its solution back.
  solver_options.update_state_every_iteration = true;
  SolveStart solve_start(hooks, parameters);
  solver_options.callbacks.push_back(&solve_start);
  RunNumberedCallbacks numbered(options.callbacks);
  if (!options.callbacks.empty()) solver_options.callbacks.push_back(&numbered);
  const int first = done;
  LbfgsRunReport report;
  for (;;) {
    const int limit = std::min(options.max_iterations,
                               hooks->BeforeSolve(done, options.max_iterations, parameters));
    CHECK_GT(limit, done) << "LbfgsSolveHooks::BeforeSolve must leave iterations to do";
    solver_options.max_num_iterations = limit - done;
    numbered.StartSolve(done - first);
    ceres::GradientProblemSolver::Summary summary;
    ceres::Solve(solver_options, problem, parameters, &summary);
    const int steps = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
    done += steps;
    report.termination_type = summary.termination_type;
    report.termination = summary.message;
    if (done == first && summary.iterations.empty() &&
        summary.termination_type == ceres::FAILURE) {
      report.start_failed = true;
    }
    // A callback that stops the solver (a time budget, a checkpoint that failed) ends
    // the run as it ends the solve.
    bool stopped = summary.termination_type == ceres::USER_SUCCESS ||
                   summary.termination_type == ceres::USER_FAILURE;
    if (!options.callbacks.empty() && !stopped &&
        numbered.PassOnLast(summary, done - first) != ceres::SOLVER_CONTINUE) {
      stopped = true;
    }
    const bool go_on = hooks->AfterSolve(summary, done, &report.termination);
    if (!go_on || stopped || report.start_failed || done >= options.max_iterations) break;
    const bool stalled = LbfgsStalled(summary);
    // Reached the hooks' limit: the next solve follows (with an empty memory).
    if (done >= limit && !stalled) continue;
    if (!stalled || steps == 0 || report.restarts >= options.max_restarts) break;
    hooks->BeforeRestart(parameters);
    ++report.restarts;
    log << "  L-BFGS stopped (" << summary.message << "); restarting from iteration " << done
        << "\n";
  }
  report.iterations = done;
  return report;
}

}  // namespace aqs
