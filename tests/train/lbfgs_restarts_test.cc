// RunLbfgsWithRestarts (train/lbfgs_restarts.h): the restart rule of end-to-end
// training, pre-training and the evaluation's auto-encoder baseline.

#include "train/lbfgs_restarts.h"

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <ceres/first_order_function.h>
#include <gtest/gtest.h>

namespace aqs {
namespace {

// The extended Rosenbrock function over n (even) numbers, sum over pairs of
// 100 (x_2i+1 - x_2i^2)^2 + (1 - x_2i)^2, whose evaluations fail (return false) while
// `failing` is set.
class Rosenbrock final : public ceres::FirstOrderFunction {
 public:
  explicit Rosenbrock(int n) : n_(n) {}
  int NumParameters() const override { return n_; }
  bool Evaluate(const double* x, double* cost, double* gradient) const override {
    if (failing) return false;
    *cost = 0.0;
    for (int i = 0; i + 1 < n_; i += 2) {
      const double a = x[i + 1] - x[i] * x[i], b = 1.0 - x[i];
      *cost += 100.0 * a * a + b * b;
      if (gradient != nullptr) {
        gradient[i] = -400.0 * a * x[i] - 2.0 * b;
        gradient[i + 1] = 200.0 * a;
      }
    }
    return true;
  }
  bool failing = false;

 private:
  int n_;
};

// The usual start: (-1.2, 1) in every pair.
Eigen::VectorXd RosenbrockStart(int n) {
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; i += 2) x.segment<2>(i) << -1.2, 1.0;
  return x;
}

ceres::GradientProblemSolver::Options LbfgsOptions(double function_tolerance) {
  ceres::GradientProblemSolver::Options options;
  options.line_search_direction_type = ceres::LBFGS;
  options.function_tolerance = function_tolerance;
  options.gradient_tolerance = 1e-12;
  options.parameter_tolerance = 1e-14;
  options.logging_type = ceres::SILENT;
  return options;
}

// Records the iterations it sees and, at each, the point in `parameters` (the solver
// updates it every iteration); stops the solver at stop_at with `stop`, and sets
// *fail_from (if not null) from iteration fail_at on.
class Recorder final : public ceres::IterationCallback {
 public:
  Recorder(const double* parameters, int n) : parameters_(parameters), n_(n) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    iterations.push_back(s.iteration);
    points.push_back(Eigen::Map<const Eigen::VectorXd>(parameters_, n_));
    if (fail != nullptr && s.iteration == fail_at) *fail = true;
    return s.iteration == stop_at ? stop : ceres::SOLVER_CONTINUE;
  }
  std::vector<int> iterations;
  std::vector<Eigen::VectorXd> points;
  int stop_at = -1;
  ceres::CallbackReturnType stop = ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  bool* fail = nullptr;
  int fail_at = -1;

 private:
  const double* parameters_;
  int n_;
};

// How often `text` occurs in `log`.
int Count(const std::string& log, const std::string& text) {
  int count = 0;
  for (size_t at = log.find(text); at != std::string::npos; at = log.find(text, at + 1)) ++count;
  return count;
}

// 0, 1, ..., last.
std::vector<int> Range(int first, int last) {
  std::vector<int> range;
  for (int i = first; i <= last; ++i) range.push_back(i);
  return range;
}

// A function tolerance that ends every solve after a few iterations: the run restarts
// from the accepted point until its budget is spent, says so at each restart, and its
// callbacks see the run's iterations numbered on, each once (a resumed run's numbers
// count from its own start); the solver options' own callbacks see each solve.
TEST(LbfgsRestartsTest, StallsRestartUntilTheBudgetIsSpent) {
  const int n = 10;
  auto* function = new Rosenbrock(n);
  ceres::GradientProblem problem(function);
  Eigen::VectorXd x = RosenbrockStart(n);
  ceres::GradientProblemSolver::Options solver_options = LbfgsOptions(0.05);
  Recorder raw(x.data(), n);
  solver_options.callbacks.push_back(&raw);
  Recorder numbered(x.data(), n);
  LbfgsRestartOptions options;
  options.max_iterations = 40;  // 5 of them done before this run
  options.callbacks.push_back(&numbered);
  std::ostringstream log;
  const LbfgsRunReport report =
      RunLbfgsWithRestarts(solver_options, problem, options, 5, x.data(), log);
  EXPECT_EQ(report.iterations, 40);
  EXPECT_GE(report.restarts, 2);
  EXPECT_EQ(report.termination_type, ceres::NO_CONVERGENCE) << report.termination;
  EXPECT_EQ(Count(log.str(), "  L-BFGS stopped (Function tolerance reached."), report.restarts)
      << log.str();
  EXPECT_EQ(numbered.iterations, Range(0, 35));
  // The last numbered point is where the run ended.
  EXPECT_EQ(numbered.points.back(), x);
  // Every solve starts at its iteration 0.
  EXPECT_EQ(std::count(raw.iterations.begin(), raw.iterations.end(), 0), report.restarts + 1);
  double cost = 0.0;
  ASSERT_TRUE(function->Evaluate(RosenbrockStart(n).data(), &cost, nullptr));
  double final_cost = 0.0;
  ASSERT_TRUE(function->Evaluate(x.data(), &final_cost, nullptr));
  EXPECT_LT(final_cost, 0.1 * cost);
}

// max_restarts bounds the restarts; with none the run is one solve.
TEST(LbfgsRestartsTest, MaxRestartsBoundsThem) {
  const int n = 10;
  ceres::GradientProblem problem(new Rosenbrock(n));
  std::vector<int> iterations;
  for (const int max_restarts : {0, 2}) {
    Eigen::VectorXd x = RosenbrockStart(n);
    LbfgsRestartOptions options;
    options.max_iterations = 200;
    options.max_restarts = max_restarts;
    std::ostringstream log;
    const LbfgsRunReport report =
        RunLbfgsWithRestarts(LbfgsOptions(0.05), problem, options, 0, x.data(), log);
    EXPECT_EQ(report.restarts, max_restarts);
    EXPECT_EQ(report.termination_type, ceres::CONVERGENCE) << report.termination;
    EXPECT_EQ(Count(log.str(), "restarting from iteration"), max_restarts);
    iterations.push_back(report.iterations);
  }
  // One solve: what Ceres alone does.
  Eigen::VectorXd x = RosenbrockStart(n);
  ceres::GradientProblemSolver::Options alone = LbfgsOptions(0.05);
  alone.max_num_iterations = 200;
  ceres::GradientProblemSolver::Summary summary;
  ceres::Solve(alone, problem, x.data(), &summary);
  EXPECT_EQ(iterations[0], static_cast<int>(summary.iterations.size()) - 1);
  EXPECT_GT(iterations[1], iterations[0]);
  EXPECT_LT(iterations[1], 200);
}

// An iteration that cannot evaluate its step (Ceres' FAILURE, here: every evaluation
// fails after iteration 6) leaves the parameters at the point accepted last, though Ceres does
// not copy its solution back after a FAILURE and the caller did not ask for
// update_state_every_iteration. The restart starts there (the hook sees it) and, once
// the evaluations work again, runs to the budget.
TEST(LbfgsRestartsTest, AFailureRestartsFromTheAcceptedPoint) {
  const int n = 10;
  class ClearFailure final : public LbfgsSolveHooks {
   public:
    explicit ClearFailure(Rosenbrock* function) : function_(function) {}
    void BeforeRestart(const double* parameters) override {
      restarted_from = Eigen::Map<const Eigen::VectorXd>(parameters, 10);
      function_->failing = false;
    }
    Eigen::VectorXd restarted_from;

   private:
    Rosenbrock* function_;
  };
  for (const int max_restarts : {0, 50}) {
    auto* function = new Rosenbrock(n);
    ceres::GradientProblem problem(function);
    Eigen::VectorXd x = RosenbrockStart(n);
    Recorder recorder(x.data(), n);
    recorder.fail = &function->failing;
    recorder.fail_at = 6;
    LbfgsRestartOptions options;
    options.max_iterations = 30;
    options.max_restarts = max_restarts;
    options.callbacks.push_back(&recorder);
    ClearFailure hooks(function);
    std::ostringstream log;
    const LbfgsRunReport report =
        RunLbfgsWithRestarts(LbfgsOptions(1e-12), problem, options, 0, x.data(), log, &hooks);
    ASSERT_GE(recorder.points.size(), 7u);
    const Eigen::VectorXd accepted = recorder.points[6];
    EXPECT_NE(accepted, RosenbrockStart(n));
    if (max_restarts == 0) {
      EXPECT_EQ(report.termination_type, ceres::FAILURE) << report.termination;
      EXPECT_EQ(report.iterations, 6);
      EXPECT_EQ(report.restarts, 0);
      EXPECT_EQ(x, accepted);
      continue;
    }
    EXPECT_EQ(report.restarts, 1);
    EXPECT_EQ(hooks.restarted_from, accepted);
    EXPECT_EQ(Count(log.str(), "  L-BFGS stopped ("), 1) << log.str();
    EXPECT_NE(log.str().find("; restarting from iteration 6\n"), std::string::npos) << log.str();
    EXPECT_EQ(report.iterations, 30);
    EXPECT_EQ(recorder.iterations, Range(0, 30));
  }
}

// A start that cannot be evaluated ends the run at once, said as start_failed (training
// then fails: it used to report 0 iterations as a finished run); a failure later, after
// iteration 0, is a stall as above.
TEST(LbfgsRestartsTest, AStartThatCannotBeEvaluatedEndsTheRun) {
  auto* function = new Rosenbrock(4);
  function->failing = true;
  ceres::GradientProblem problem(function);
  Eigen::VectorXd x = RosenbrockStart(4);
  LbfgsRestartOptions options;
  options.max_iterations = 30;
  options.max_restarts = 50;
  std::ostringstream log;
  LbfgsRunReport report =
      RunLbfgsWithRestarts(LbfgsOptions(1e-12), problem, options, 0, x.data(), log, nullptr);
  EXPECT_TRUE(report.start_failed);
  EXPECT_EQ(report.termination_type, ceres::FAILURE);
  EXPECT_EQ(report.iterations, 0);
  EXPECT_EQ(report.restarts, 0);
  EXPECT_EQ(x, RosenbrockStart(4));
  function->failing = false;
  report = RunLbfgsWithRestarts(LbfgsOptions(1e-12), problem, options, 0, x.data(), log, nullptr);
  EXPECT_FALSE(report.start_failed);
  EXPECT_EQ(report.iterations, 30);
}

// Hooks that end each solve every 7 iterations continue the run without a restart (each
// solve a new L-BFGS memory), and one that says stop after a solve ends it; a callback
// that stops the solver ends the run as well.
TEST(LbfgsRestartsTest, HooksAndCallbacksEndSolvesAndRuns) {
  const int n = 10;
  ceres::GradientProblem problem(new Rosenbrock(n));
  class Segments final : public LbfgsSolveHooks {
   public:
    int BeforeSolve(int done, int max_iterations, double* parameters) override {
      starts.push_back(done);
      return done + 7;  // capped at max_iterations by the run
    }
    bool AfterSolve(const ceres::GradientProblemSolver::Summary& summary, int done,
                    std::string* termination) override {
      *termination += " (segment)";
      return done < stop_after;
    }
    std::vector<int> starts;
    int stop_after = 1000;
  };
  {
    Eigen::VectorXd x = RosenbrockStart(n);
    Recorder recorder(x.data(), n);
    LbfgsRestartOptions options;
    options.max_iterations = 30;
    options.callbacks.push_back(&recorder);
    Segments hooks;
    std::ostringstream log;
    const LbfgsRunReport report =
        RunLbfgsWithRestarts(LbfgsOptions(1e-12), problem, options, 0, x.data(), log, &hooks);
    EXPECT_EQ(report.iterations, 30);
    EXPECT_EQ(report.restarts, 0);
    EXPECT_EQ(hooks.starts, (std::vector<int>{0, 7, 14, 21, 28}));
    EXPECT_EQ(recorder.iterations, Range(0, 30));
    EXPECT_NE(report.termination.find(" (segment)"), std::string::npos);
    EXPECT_EQ(log.str(), "");
    EXPECT_EQ(recorder.points.back(), x);
    hooks.starts.clear();
    hooks.stop_after = 14;
    // Into the same buffer: the recorder holds x.data() (assigning a new vector would
    // swap buffers and free the one it reads; AddressSanitizer found that).
    x.head(n) = RosenbrockStart(n);
    recorder.points.clear();
    EXPECT_EQ(RunLbfgsWithRestarts(LbfgsOptions(1e-12), problem, options, 0, x.data(), log,
                                   &hooks)
                  .iterations,
              14);
    EXPECT_EQ(hooks.starts, (std::vector<int>{0, 7}));
    ASSERT_FALSE(recorder.points.empty());
    EXPECT_EQ(recorder.points.back(), x);
  }
  for (const ceres::CallbackReturnType stop :
       {ceres::SOLVER_TERMINATE_SUCCESSFULLY, ceres::SOLVER_ABORT}) {
    Eigen::VectorXd x = RosenbrockStart(n);
    Recorder recorder(x.data(), n);
    recorder.stop_at = 12;
    recorder.stop = stop;
    LbfgsRestartOptions options;
    options.max_iterations = 30;
    options.callbacks.push_back(&recorder);
    std::ostringstream log;
    const LbfgsRunReport report =
        RunLbfgsWithRestarts(LbfgsOptions(1e-12), problem, options, 0, x.data(), log);
    EXPECT_EQ(report.iterations, 12);
    EXPECT_EQ(report.termination_type, stop == ceres::SOLVER_ABORT ? ceres::USER_FAILURE
                                                                    : ceres::USER_SUCCESS);
    EXPECT_EQ(recorder.iterations.back(), 12);
  }
}

// AtSolveStart sees the start point of every solve, once: the point BeforeSolve left
// (here moved, as a latent refit moves the latents; BeforeSolve runs before restarts
// too), and it comes before the numbered callbacks see that iteration.
TEST(LbfgsRestartsTest, EverySolveStartIsSeenWhereItStarts) {
  const int n = 10;
  ceres::GradientProblem problem(new Rosenbrock(n));
  Eigen::VectorXd x = RosenbrockStart(n);
  class Starts final : public LbfgsSolveHooks {
   public:
    Starts(const Eigen::VectorXd& x, const Recorder& recorder) : x_(x), recorder_(recorder) {}
    int BeforeSolve(int done, int max_iterations, double* parameters) override {
      if (done % 2 == 0) parameters[0] += 1e-3;  // a new point, as after a refit
      left.push_back(x_);
      return std::min(max_iterations, done + 9);
    }
    void AtSolveStart(const double* parameters) override {
      seen.push_back(Eigen::Map<const Eigen::VectorXd>(parameters, x_.size()));
      numbered_before.push_back(recorder_.iterations.size());
    }
    std::vector<Eigen::VectorXd> left, seen;
    std::vector<size_t> numbered_before;

   private:
    const Eigen::VectorXd& x_;
    const Recorder& recorder_;
  };
  Recorder numbered(x.data(), n);
  Starts hooks(x, numbered);
  LbfgsRestartOptions options;
  options.max_iterations = 40;
  options.callbacks.push_back(&numbered);
  std::ostringstream log;
  // A function tolerance at which solves also stall between the hooks' segments.
  const LbfgsRunReport report =
      RunLbfgsWithRestarts(LbfgsOptions(0.05), problem, options, 0, x.data(), log, &hooks);
  EXPECT_GE(report.restarts, 1) << log.str();
  EXPECT_EQ(report.iterations, 40);
  EXPECT_GE(hooks.seen.size(), 5u);
  EXPECT_EQ(hooks.seen, hooks.left);
  // The run's start is seen before the numbered callbacks see iteration 0; a later
  // solve's start after its predecessor's last iteration.
  EXPECT_EQ(hooks.numbered_before[0], 0u);
  for (size_t k = 1; k < hooks.numbered_before.size(); ++k) {
    EXPECT_GT(hooks.numbered_before[k], hooks.numbered_before[k - 1]);
  }
}

}  // namespace
}  // namespace aqs
