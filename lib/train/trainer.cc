#include "train/trainer.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include <ceres/first_order_function.h>
#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>
#include <ceres/iteration_callback.h>

#include "dist/communicator.h"
#include "model/model_io.h"
#include "train/end_to_end_objective.h"
#include "train/latent_refit.h"
#include "train/lbfgs_restarts.h"
#include "train/progress.h"
#include "util/atomic_file.h"
#include "util/blas.h"
#include "util/iteration_log.h"
#include "util/line_reader.h"
#include "util/number_format.h"
#include "util/parallel_for.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

std::string LogPath(const std::string& dir) { return dir + "/train/log.csv"; }
constexpr char kLogHeader[] =
    "iteration,loss,mean_surface_error,max_surface_error,gradient_norm,step_norm,seconds,"
    "function_evaluations,factorizations_per_pose,cg_solves_per_pose\n";

// The seconds column (the 7th, kLogHeader's) of a row of the log into *seconds: what the
// runs before this one spent. False, *seconds 0, if the row has no such number >= 0.
bool LoggedSeconds(const std::string& row, double* seconds) {
  std::stringstream fields(row);
  std::string field;
  for (int k = 0; k < 7 && std::getline(fields, field, ','); ++k) {
    if (k == 6 && ParseDouble(field, seconds) && *seconds >= 0.0) return true;
  }
  *seconds = 0.0;
  return false;
}

class TrainingCallback final : public ceres::IterationCallback {
 public:
  // seconds_before: what the runs before spent (the log's seconds go on from there).
  TrainingCallback(const TrainOptions& options, ActiveModel* model, EndToEndObjective* objective,
                   const Eigen::VectorXd& parameters, int iterations_before,
                   double seconds_before, std::ostream& log)
      : options_(options),
        model_(model),
        objective_(*objective),
        parameters_(parameters),
        first_(iterations_before),
        seconds_before_(seconds_before),
        log_(log),
        counters_before_(objective->total_counters()) {}

  bool budget_reached() const { return budget_reached_; }

  // Called through RunLbfgsWithRestarts' numbered callbacks: s.iteration counts from the
  // start of this run (0: its start point) across restarts and refits, each iteration
  // once, also one that ended a solve by a convergence test.
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    const int iteration = first_ + s.iteration;
    // The accepted point's equilibria, kept for the restart, final evaluation and saves
    // after a line search that evaluates more trial points than the objective
    // remembers, or evaluates this point again from another start.
    // Its surface errors too (the last evaluation may have been a later trial point).
    double mean_error = objective_.mean_surface_error();
    double max_error = objective_.max_surface_error();
    if (objective_.KeepStatesOf(parameters_.data())) {
      objective_.KeptSurfaceErrors(&mean_error, &max_error);
    }
    const double elapsed = timer_.Seconds();
    // What the evaluations since the previous row cost, per pose: stiffness factorizations
    // and solves by CG on an earlier factor (the objective's counters, summed over ranks).
    const EvaluationCounters cost = objective_.total_counters().Since(counters_before_);
    counters_before_ = objective_.total_counters();
    const double per_pose = 1.0 / std::max(1, model_->num_poses());
    const double factorizations = cost.factorizations * per_pose;
    const double cg_solves = cost.reused_solves * per_pose;
    // A resumed run's start point: logged (and saved) by the run before.
    if (s.iteration == 0 && first_ > 0) return ceres::SOLVER_CONTINUE;
    if (options_.log_every > 0 && (s.iteration % options_.log_every == 0)) {
      char line[360];
      // The iteration cap's estimate, or the time budget's rest if that ends sooner.
      const double remaining =
          ProgressEta(iteration - first_, options_.max_iterations, first_, elapsed,
                      options_.max_seconds > 0 ? options_.max_seconds : -1.0);
      std::snprintf(line, sizeof(line),
                    "  train iter %5d/%d  loss %.6e  surface mean %.4g max %.4g  |g| %.3e  "
                    "fact/pose %.2f  %s  ETA %s\n",
                    iteration, options_.max_iterations, s.cost, mean_error, max_error,
                    s.gradient_norm, factorizations,
                    FormatDuration(elapsed).c_str(), FormatDuration(remaining).c_str());
      log_ << line << std::flush;
    }
    if (!options_.model_directory.empty()) {
      char row[400];
      std::snprintf(row, sizeof(row), "%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.6f,%d,%.6g,%.6g\n",
                    iteration, s.cost, mean_error, max_error, s.gradient_norm, s.step_norm,
                    seconds_before_ + elapsed,
                    s.line_search_function_evaluations, factorizations, cg_solves);
      // Appended before the checkpoint of this iteration: a kill in between leaves one
      // row more than the checkpoint, which the next run drops (PrepareIterationLog).
      std::string log_error;
      if (!AppendLogRow(LogPath(options_.model_directory), row, &log_error) && !log_warned_) {
        log_ << "  warning: " << log_error << "; training goes on (the checkpoints hold its "
             << "state)\n";
        log_warned_ = true;
      }
      if (CheckpointDue(iteration, s.iteration, options_.checkpoint_every) &&
          !Save(iteration, s.cost)) {
        return ceres::SOLVER_ABORT;
      }
    }
    if (options_.max_seconds > 0 && elapsed > options_.max_seconds) {
      log_ << "  time budget of " << FormatDuration(options_.max_seconds) << " reached\n";
      budget_reached_ = true;
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return ceres::SOLVER_CONTINUE;
  }

  // Copies the current parameters and states into the model and saves them with the
  // checkpoint (iterations done, loss), as one unit (SaveLearnedState).
  bool Save(int iteration, double loss) {
    CopyToModel();
    model_->checkpoint.iterations = iteration;
    model_->checkpoint.loss = loss;
    std::string error;
    if (!SaveLearnedState(options_.model_directory, *model_, &error)) {
      log_ << "  checkpoint failed: " << error << "\n";
      return false;
    }
    return true;
  }

  void CopyToModel() {
    const int np = model_->decoder->num_parameters();
    model_->decoder_params = parameters_.head(np);
    model_->latents = Eigen::Map<const Eigen::MatrixXd>(parameters_.data() + np,
                                                        model_->latent_dim(), model_->num_poses());
    // The equilibria of the accepted point (the line search may have evaluated others
    // after it), from the ranks that own them.
    objective_.CollectStates(parameters_.data(), &model_->states);
  }

 private:
  const TrainOptions& options_;
  ActiveModel* model_;
  EndToEndObjective& objective_;
  const Eigen::VectorXd& parameters_;
  int first_;  // iterations done before this run
  double seconds_before_;  // and the seconds they took (train/log.csv)
  std::ostream& log_;
  WallTimer timer_;
  bool budget_reached_ = false;
  bool log_warned_ = false;  // a failed append of the CSV log is said once
  EvaluationCounters counters_before_;  // the objective's totals at the previous row
};

// A round of latent refits at the accepted point `parameters` ([decoder; latents]),
// shared among the ranks of a distributed run (EndToEndObjective::RefitLatents): the
// refitted latents go back into `parameters`, and their equilibria become the
// objective's warm starts.
void RefitLatents(ActiveModel* model, EndToEndObjective* objective, double* parameters,
                  std::ostream& log) {
  const LatentRefitReport report = objective->RefitLatents(model, parameters);
  char line[256];
  std::snprintf(line, sizeof(line),
                "  latent refit: loss %.6e -> %.6e (%d of %d poses improved, %d failed; %s)\n",
                report.loss_before, report.loss_after, report.improved, model->num_poses(),
                report.failed, FormatDuration(report.seconds).c_str());
  log << line << std::flush;
}

// Logs the start of training: the poses, parameters and starting loss (and the
// iterations a resumed run has done), how the poses spread over the ranks, and the
// solver layout (TrainOptions::max_factor_cache_gb) for this rank's poses.
void LogTrainingStart(const TrainOptions& options, const ActiveModel& model,
                      const EndToEndObjective& objective, double cost, int iterations_before,
                      std::ostream& log) {
  const Communicator* communicator = options.communicator;
  const int np = model.decoder->num_parameters();
  char start_loss[32];
  std::snprintf(start_loss, sizeof(start_loss), "%.12g", cost);
  log << "train: " << model.num_poses() << " poses, " << np << " decoder parameters + "
      << model.latent_dim() << " x " << model.num_poses() << " latents; start loss "
      << start_loss << ", surface error mean " << objective.mean_surface_error() << " max "
      << objective.max_surface_error();
  if (iterations_before > 0) {
    log << " (resuming after " << iterations_before << " iterations)";
  }
  log << "\n";
  if (objective.distributed()) {
    log << "train: poses over " << communicator->Description() << ", per rank:";
    for (int r = 0; r < communicator->size(); ++r) {
      log << " " << OwnedIndices(model.num_poses(), r, communicator->size()).size();
    }
    const int spare = communicator->size() - model.num_poses();
    if (spare == 1) {
      log << " (rank " << model.num_poses() << " has no pose and stays idle)";
    } else if (spare > 1) {
      log << " (ranks " << model.num_poses() << " to " << communicator->size() - 1
          << " have no pose and stay idle)";
    }
    log << "\n";
  }
  {
    // The solver layout (TrainOptions::max_factor_cache_gb), for this rank's poses.
    const size_t owned = objective.owned_poses().size();
    const double gb = objective.factor_gb(), total = owned * gb;
    char layout[512];
    if (objective.solver_per_pose()) {
      std::snprintf(layout, sizeof(layout),
                    "train: one solver and stiffness factor per pose (%zu x %.3g GB = %.3g GB, "
                    "within the factor cache of %.3g GB)\n",
                    owned, gb, total, options.max_factor_cache_gb);
    } else if (total > options.max_factor_cache_gb) {
      const int stored = objective.num_stored_factors();
      std::snprintf(layout, sizeof(layout),
                    "train: one solver per thread (the factors of %zu poses, %zu x %.3g GB = "
                    "%.3g GB, exceed the factor cache of %.3g GB); %d of the poses keep "
                    "their factor in single precision (%d x %.3g GB = %.3g GB)\n",
                    owned, owned, gb, total, options.max_factor_cache_gb, stored, stored,
                    objective.stored_factor_gb(), stored * objective.stored_factor_gb());
    } else {
      std::snprintf(layout, sizeof(layout), "train: one solver per thread\n");
    }
    log << layout;
  }
}

// Ceres' L-BFGS for end-to-end training (its callback, which logs and saves the state,
// goes through RunLbfgsWithRestarts' numbered callbacks); max_num_iterations is set per
// solve.
ceres::GradientProblemSolver::Options TrainingSolverOptions(const TrainOptions& options) {
  ceres::GradientProblemSolver::Options solver_options;
  solver_options.line_search_direction_type = ceres::LBFGS;
  solver_options.max_lbfgs_rank = 10;
  solver_options.max_line_search_step_expansion = options.max_step_expansion;
  solver_options.use_approximate_eigenvalue_bfgs_scaling = options.lbfgs_scaling;
  solver_options.function_tolerance = 1e-10;
  solver_options.gradient_tolerance = 1e-12;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.logging_type = ceres::SILENT;
  solver_options.update_state_every_iteration = true;  // the callback saves `parameters`
  return solver_options;
}

// What end-to-end training does between its L-BFGS solves (RunLbfgsWithRestarts): the
// latent refits of options (before iteration 0 of a fresh run, then every
// latent_refit_every iterations; each ends a solve, and the next starts with an empty
// memory), the time budget (counted by budget_timer), the failed pose named in the
// termination, and a restart from the accepted point's equilibria.
class TrainingSolveHooks final : public LbfgsSolveHooks {
 public:
  TrainingSolveHooks(const TrainOptions& options, const WallTimer& budget_timer, int done,
                     ActiveModel* model, EndToEndObjective* objective,
                     TrainingCallback* callback, TrainReport* report, std::ostream& log)
      : options_(options),
        budget_timer_(budget_timer),
        model_(model),
        objective_(objective),
        callback_(callback),
        report_(report),
        log_(log),
        refits_(options.latent_refit_iterations > 0) {
    const int every = options.latent_refit_every;
    // A refit runs after its iteration's checkpoint: a run resumed there refits first,
    // unless the checkpoint was saved after the refit (a run that ended in it, the first
    // refit's too).
    const TrainingCheckpoint& saved = model->checkpoint;
    const bool refitted_here = saved.iterations == done && saved.latent_refit_at == done;
    const bool due = done == 0 || (every > 0 && done % every == 0);
    next_refit_ = due && !refitted_here ? done
                  : every > 0           ? (done / every + 1) * every
                                        : options.max_iterations;
  }

  int BeforeSolve(int done, int max_iterations, double* parameters) override {
    if (refits_ && done >= next_refit_) {
      RefitLatents(model_, objective_, parameters, log_);
      ++report_->latent_refits;
      model_->checkpoint.latent_refit_at = done;  // saved with the next checkpoint
      const int every = options_.latent_refit_every;
      next_refit_ = every > 0 ? done + every : max_iterations;
    }
    return refits_ ? std::min(max_iterations, next_refit_) : max_iterations;
  }

  bool AfterSolve(const ceres::GradientProblemSolver::Summary& summary, int done,
                  std::string* termination) override {
    if (summary.termination_type == ceres::FAILURE && !objective_->last_failure().empty()) {
      // Name the pose and the cause of the failed evaluation (Ceres' message does not).
      *termination += " (" + objective_->last_failure() + ")";
    }
    const bool out_of_time =
        options_.max_seconds > 0 && budget_timer_.Seconds() > options_.max_seconds;
    if (out_of_time && !callback_->budget_reached()) {
      log_ << "  time budget of " << FormatDuration(options_.max_seconds)
           << " reached during a line search (its last step is dropped)\n";
    }
    return !out_of_time && !callback_->budget_reached();
  }

  void BeforeRestart(const double* parameters) override {
    objective_->UseStatesOf(parameters);  // restart from the accepted point's equilibria
  }

  // Every solve's start point is the accepted one until the line search accepts
  // another: after a latent refit it is a new point (the refitted latents), whose
  // equilibria a failed first line search or the time budget would otherwise leave to
  // those of a trial point for the final evaluation and the saves.
  void AtSolveStart(const double* parameters) override {
    objective_->KeepStatesOf(parameters);
  }

 private:
  const TrainOptions& options_;
  const WallTimer& budget_timer_;
  ActiveModel* model_;
  EndToEndObjective* objective_;
  TrainingCallback* callback_;
  TrainReport* report_;
  std::ostream& log_;
  const bool refits_;
  int next_refit_;  // the iteration of the next latent refit
};

// Ceres' L-BFGS on `problem` from *parameters ([decoder; latents]; `done` iterations
// done before this run), with the latent refits of options and restarts from the
// accepted point where the line search stalls (the loss is only as smooth as the
// equilibria are converged, so it can stall far from a minimum: L-BFGS restarts with an
// empty memory, a steepest-descent step first, as long as each restart makes progress;
// train/lbfgs_restarts.h), until the iterations, the time budget (counted by
// budget_timer) or the progress run out. Returns the iterations done in all; sets
// report's termination, latent_refits and restarts.
int RunTrainingSolves(const TrainOptions& options, const ceres::GradientProblem& problem,
                      const WallTimer& budget_timer, int done, ActiveModel* model,
                      EndToEndObjective* objective, TrainingCallback* callback,
                      Eigen::VectorXd* parameters, TrainReport* report, bool* start_failed,
                      std::ostream& log) {
  TrainingSolveHooks hooks(options, budget_timer, done, model, objective, callback, report, log);
  LbfgsRestartOptions restart_options;
  restart_options.max_iterations = options.max_iterations;
  restart_options.max_restarts = options.max_restarts;
  restart_options.callbacks.push_back(callback);  // numbered across restarts and refits
  const LbfgsRunReport run =
      RunLbfgsWithRestarts(TrainingSolverOptions(options), problem, restart_options, done,
                           parameters->data(), log, &hooks);
  report->termination = run.termination;
  report->restarts += run.restarts;
  *start_failed = run.start_failed;
  return run.iterations;
}

}  // namespace

bool CheckpointDue(int iteration, int run_iteration, int every) {
  return every > 0 && run_iteration > 0 && iteration % every == 0;
}

bool TrainEndToEnd(const TrainOptions& options, ActiveModel* model, TrainReport* report,
                   std::ostream& log, std::string* error) {
  WallTimer timer;
  // Validated here too, for library callers (the apps' jobs validate before).
  std::string invalid;
  if (!options.Validate(&invalid)) {
    *error = "training options: " + invalid;
    return false;
  }
  if (!model->decoder) {
    *error = "the model has no decoder yet: pre-train it first (aqs_pretrain)";
    return false;
  }
  if (model->num_poses() == 0) {
    *error = "the model has no training poses";
    return false;
  }
  const Communicator* communicator = options.communicator;
  // Poses run in parallel with one thread each: BLAS single-threaded meanwhile (the
  // final evaluation included).
  auto blas = std::make_unique<ScopedBlasThreads>(options.num_threads > 1 ? 1 : BlasThreads());
  if (communicator != nullptr && communicator->size() > 1 && !communicator->is_root()) {
    // Another rank: evaluations of its poses, as rank 0 commands.
    EndToEndObjective objective(options, *model);
    const bool ok = objective.Serve(model);
    error->clear();
    return ok;
  }
  // Rank 0 (or the one process). The objective stops the other ranks when it is
  // destroyed, whichever way this function returns.
  auto owned_objective = std::make_unique<EndToEndObjective>(options, *model);
  EndToEndObjective* objective = owned_objective.get();
  report->iterations_before =
      options.model_directory.empty() ? 0 : model->checkpoint.iterations;
  const int remaining = options.max_iterations - report->iterations_before;
  double seconds_before = 0.0;
  if (!options.model_directory.empty()) {
    std::error_code code;
    fs::create_directories(options.model_directory + "/train", code);
    int last_row = -1;
    std::string last_line;
    if (!PrepareIterationLog(LogPath(options.model_directory), kLogHeader,
                             report->iterations_before, &last_row, error, &last_line)) {
      return false;
    }
    if (!LoggedSeconds(last_line, &seconds_before) && !last_line.empty()) {
      log << "train: warning: the last row of " << LogPath(options.model_directory)
          << " has no seconds >= 0 (its 7th field): the log's seconds start again at 0\n";
    }
    if (report->iterations_before > 0 && last_row < report->iterations_before) {
      // The learned state is whole (it is saved as one unit); only the record is short.
      log << "train: warning: " << options.model_directory << "/train/log.csv has rows up to "
          << (last_row < 0 ? std::string("none") : "iteration " + std::to_string(last_row))
          << ", but the checkpoint is of iteration " << report->iterations_before
          << " (the log was cut or replaced apart from the model): its rows "
          << last_row + 1 << " to " << report->iterations_before
          << " are missing; training resumes after the checkpoint\n";
    }
  }
  // The loss's weights, saved with the checkpoints: a run resumed with others says so.
  const std::string weights = "latent " + FormatDouble(options.latent_regularization) +
                              " energy " + FormatDouble(options.energy_regularization) +
                              " decoder " + FormatDouble(options.decoder_regularization);
  if (report->iterations_before > 0 && !model->checkpoint.loss_weights.empty() &&
      model->checkpoint.loss_weights != weights) {
    log << "train: note: the " << report->iterations_before << " iterations done were trained "
        << "with other loss weights (" << model->checkpoint.loss_weights << "; now " << weights
        << "): the loss column of train/log.csv changes meaning after iteration "
        << report->iterations_before << "\n";
  }
  model->checkpoint.loss_weights = weights;
  Eigen::VectorXd parameters = objective->ModelParameters();
  double cost = 0;
  if (!objective->Evaluate(parameters.data(), &cost, nullptr)) {
    *error = "the starting point cannot be simulated: " + objective->last_failure();
    return false;
  }
  report->initial_loss = cost;
  report->initial_mean_surface_error = objective->mean_surface_error();
  LogTrainingStart(options, *model, *objective, cost, report->iterations_before, log);
  if (remaining <= 0) {
    log << "train: all " << options.max_iterations << " iterations are done already\n";
  }

  // The budget counts from here; a line search past it fails at once.
  objective->set_time_limit(options.max_seconds);
  const EvaluationCounters cost_before = objective->total_counters();
  WallTimer budget_timer;
  ceres::GradientProblem problem(owned_objective.release());  // owns the objective
  TrainingCallback callback(options, model, objective, parameters, report->iterations_before,
                            seconds_before, log);
  int done = report->iterations_before;
  if (remaining > 0) {
    bool start_failed = false;
    done = RunTrainingSolves(options, problem, budget_timer, done, model, objective, &callback,
                             &parameters, report, &start_failed, log);
    const bool out_of_time =
        options.max_seconds > 0 && budget_timer.Seconds() > options.max_seconds;
    if (start_failed && !out_of_time) {
      // Not a training that ended early (as where a latent refit used up the time
      // budget, which fails the next evaluation at once): none could start (it used to
      // exit 0 here, with 0 iterations).
      *error = "the gradient at the starting point cannot be computed: " + report->termination;
      return false;
    }
  } else {
    report->termination = "no iterations left";
  }
  // Final state: evaluate the returned parameters (also refreshes states and errors), with
  // the BLAS threads of training's evaluations (one per pose thread: no oversubscription).
  report->iteration_cost = objective->total_counters().Since(cost_before);
  objective->set_time_limit(0.0);
  objective->AllowRetryFromRest();
  objective->UseStatesOf(parameters.data());  // the accepted point's equilibria
  if (!objective->Evaluate(parameters.data(), &cost, nullptr)) {
    *error = "the final point cannot be simulated: " + objective->last_failure();
    return false;
  }
  blas.reset();
  report->final_loss = cost;
  report->mean_surface_error = objective->mean_surface_error();
  report->max_surface_error = objective->max_surface_error();
  report->iterations = done;
  callback.CopyToModel();
  if (!options.model_directory.empty() && !callback.Save(report->iterations, cost)) {
    *error = "could not save the trained state to " + options.model_directory;
    return false;
  }
  objective->StopWorkers(true);
  report->seconds = timer.Seconds();
  log << "train: " << report->iterations << " iterations, loss " << report->initial_loss << " -> "
      << report->final_loss << ", surface error mean " << report->mean_surface_error << " max "
      << report->max_surface_error << " (" << FormatDuration(report->seconds) << "; "
      << report->termination << ")\n";
  return true;
}

}  // namespace aqs
