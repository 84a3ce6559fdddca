// EndToEndObjective's evaluation (Evaluate and its parts: the per-pose solves, warm
// starts and adjoints, the reductions over ranks, back-propagation through the decoder).
// Its construction, commands to other ranks, remembered states and latent refits are in
// end_to_end_objective.cc.
#include "train/end_to_end_objective.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <glog/logging.h>

#include "diff/actuation_force_products.h"
#include "geometry/embedding.h"
#include "train/line_search_start.h"
#include "util/fault_injection.h"
#include "util/parallel_for.h"

namespace aqs {

void EndToEndObjective::PredictState(int p, Worker* worker) const {
  const ActuationMatrix& before = state_actuations_[p];
  StiffnessFactorization& factorization = *worker->solver->stiffness_factorization();
  if (before.cols() != physics_.num_elements() || !factorization.factorized()) return;
  const ActuationMatrix after = worker->solver->actuation();
  const ActuationMatrix delta = after - before;
  const Eigen::Map<const Eigen::MatrixXd> direction(delta.data(), delta.size(), 1);
  // dx = K^-1 (-B delta) with the pose's last factor, an approximate K^-1 at this state.
  const Eigen::MatrixXd rhs =
      ActuationForceProducts(physics_, factorization.pattern(), states_[p], before, direction, 1);
  const Eigen::MatrixXd dx = factorization.SolveFree(rhs);
  const Eigen::Matrix3Xd predicted = states_[p] + factorization.ScatterFree(dx.data());
  // Kept only where it lowers the largest force under the new actuation.
  const double warm = worker->solver->MaxFreeForce();
  worker->solver->SetPositions(predicted);
  if (!(worker->solver->MaxFreeForce() < warm)) worker->solver->SetPositions(states_[p]);
}

bool EndToEndObjective::StartOnLine(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to,
                                    double t, const Eigen::Matrix3Xd& last,
                                    Worker* worker) const {
  const Eigen::Index nv = model_.mesh.num_vertices();
  if (from.cols() != nv || to.cols() != nv) return false;  // a pose that had not converged
  double best = worker->solver->MaxFreeForce();
  const Eigen::Matrix3Xd start = worker->solver->positions();
  Eigen::Matrix3Xd chosen;
  auto consider = [&](const Eigen::Matrix3Xd& candidate) {
    worker->solver->SetPositions(candidate);
    const double force = worker->solver->MaxFreeForce();
    if (force < best) {
      best = force;
      chosen = candidate;
    }
  };
  consider(from + t * (to - from));
  // With the last evaluation at one end, the start already there is that end's
  // first-order prediction: the quadratic through the other end with its slope.
  Eigen::Matrix3Xd curved;
  if (CurvedLineStart(from, to, t, last, start, &curved)) consider(curved);
  worker->solver->SetPositions(chosen.cols() == nv ? chosen : start);
  return chosen.cols() == nv;
}

bool EndToEndObjective::Evaluate(const double* parameters, double* cost, double* gradient) const {
  last_failure_.clear();
  if (deadline_ > 0.0 && timer_.Seconds() > deadline_) {
    last_failure_ = "the time limit has passed";
    return false;
  }
  if (distributed()) {
    SendCommand(gradient != nullptr ? kEvaluateWithGradient : kEvaluate, parameters);
  }
  return EvaluateHere(parameters, cost, gradient);
}

namespace {

// Sums `counters` over the ranks onto rank 0 (collective).
void SumCountersToRoot(const Communicator& communicator, EvaluationCounters* counters) {
  EvaluationCounters& c = *counters;
  double sums[12] = {double(c.factorizations),   double(c.adjoint_factorizations),
                     double(c.reused_solves),    double(c.cg_iterations),
                     double(c.lbfgs_iterations), double(c.newton_steps),
                     double(c.retries_from_rest), c.solve_seconds,
                     c.adjoint_seconds,          double(c.unstable_escapes),
                     double(c.shifted_adjoints), double(c.line_starts)};
  communicator.SumToRoot(sums, 12);
  c.factorizations = static_cast<int>(sums[0]);
  c.adjoint_factorizations = static_cast<int>(sums[1]);
  c.reused_solves = static_cast<int>(sums[2]);
  c.cg_iterations = static_cast<int>(sums[3]);
  c.lbfgs_iterations = static_cast<int>(sums[4]);
  c.newton_steps = static_cast<int>(sums[5]);
  c.retries_from_rest = static_cast<int>(sums[6]);
  c.solve_seconds = sums[7];
  c.adjoint_seconds = sums[8];
  c.unstable_escapes = static_cast<int>(sums[9]);
  c.shifted_adjoints = static_cast<int>(sums[10]);
  c.line_starts = static_cast<int>(sums[11]);
}

// Adds a solve's work to the pose's counters.
void CountSolve(const QuasistaticSolveReport& report, EvaluationCounters* counters) {
  counters->factorizations += report.factorizations;
  counters->reused_solves += report.reused_steps;
  counters->lbfgs_iterations += report.lbfgs_iterations;
  counters->newton_steps += report.newton_steps;
}

// Whatever the outcome of a pose's evaluation, the factor its solver holds at the end is
// the pose's to keep (none after a failure: it may belong to a state far from the next
// evaluation's). Acts on destruction; `stored` null: the pose keeps no factor.
class KeepFactorOnExit {
 public:
  KeepFactorOnExit(StiffnessFactorization* factorization, StoredStiffnessFactor* stored,
                   const std::string* failure)
      : factorization_(factorization), stored_(stored), failure_(failure) {}
  KeepFactorOnExit(const KeepFactorOnExit&) = delete;
  KeepFactorOnExit& operator=(const KeepFactorOnExit&) = delete;
  ~KeepFactorOnExit() {
    if (stored_ == nullptr) return;
    if (failure_->empty() && factorization_->factor_rounded()) {
      stored_->aged = factorization_->refresh_requested();  // the values are those restored
    } else if (failure_->empty()) {
      factorization_->StoreFactor(stored_);
    } else {
      stored_->factor.Clear();
    }
  }

 private:
  StiffnessFactorization* factorization_;
  StoredStiffnessFactor* stored_;
  const std::string* failure_;
};

}  // namespace

double EndToEndObjective::LossScale() const {
  return 1.0 / (static_cast<double>(num_poses_) * model_.num_surface_vertices());
}

double EndToEndObjective::EnergyScale() const {
  return options_.energy_regularization /
         (static_cast<double>(num_poses_) * physics_.stiffness_volume());
}

const char* EndToEndObjective::StartPose(int k, const ActuationMatrix& a, Worker* w) const {
  const int p = owned_[k];
  w->solver->SetFixedPositions(fixed_positions_[p]);
  w->solver->actuation() = a;
  w->solver->SetPositions(states_[p]);
  if (solver_per_pose_) {
    PredictState(p, w);
    return "own factor";
  }
  StiffnessFactorization* factorization = w->solver->stiffness_factorization();
  const bool restored =
      k < num_stored_factors_ && factorization->RestoreFactor(stored_factors_[k]);
  const char* start_kind = "no factor";
  if (restored) {
    start_kind = factorization->refresh_requested() ? "stored aged" : "stored";
    PredictState(p, w);
  } else {
    factorization->RequestRefresh();  // the factor is another pose's
  }
  // The pose's own earlier factor preconditions L-BFGS; without one, the thread's
  // rotation-fixed factor (kept between solves) does.
  QuasistaticSolverOptions solver_options = w->solver->options();
  solver_options.lbfgs_reuses_factor = restored;
  w->solver->set_options(solver_options);
  return start_kind;
}

void EndToEndObjective::RecordPoseLoss(int p, const Eigen::Matrix3Xd& x, const ActuationMatrix& a,
                                       Worker* w, Eigen::Matrix3Xd* diff,
                                       ActuationMatrix* energy_da) const {
  *diff = EmbeddedPositions(model_.embedding, model_.mesh.tets, x) - model_.poses[p].surface;
  pose_loss_[p] = diff->squaredNorm() * LossScale();
  if (options_.energy_regularization > 0.0) {
    // The equilibrium-energy regularizer (TrainOptions::energy_regularization); its
    // gradient dE/da at fixed x is the total one at an equilibrium. The element SVDs are
    // those of the solve's last energy evaluation, at x as a rule.
    const double energy = physics_.EnergyActuationGradient(
        x, a, energy_da, 1, &w->solver->stiffness_factorization()->polar_cache());
    pose_loss_[p] += EnergyScale() * energy;
  }
  const Eigen::VectorXd distance = diff->colwise().norm();
  pose_mean_[p] = distance.mean();
  pose_max_[p] = distance.maxCoeff();
}

bool EndToEndObjective::PoseGradient(int p, const ActuationMatrix& a, bool with_gradient,
                                     Worker* w, Eigen::Matrix3Xd* solved,
                                     ActuationMatrix* dl_da, Counters* counters,
                                     AdjointTrace* trace) const {
  WallTimer adjoint_timer;
  StiffnessFactorization& factorization = *w->solver->stiffness_factorization();
  const FactorizationCounters before = factorization.counters();
  // The escapes' solves, counted there.
  int escape_factorizations = 0, escape_reused = 0, escape_indefinite = 0;
  ActuationMatrix energy_da;  // dE/da at the equilibrium (energy_regularization)
  // An equilibrium whose exact stiffness is not positive definite is unstable (a
  // saddle of the energy): the adjoint cannot use it and the pose would not stay
  // there. Leave it by a small perturbation and solve again, at most kMaxEscapes times.
  for (int escape = 0;; ++escape) {
    *solved = w->solver->positions();
    const Eigen::Matrix3Xd& x = *solved;
    converged_once_[p] = 1;
    Eigen::Matrix3Xd diff;
    RecordPoseLoss(p, x, a, w, &diff, &energy_da);
    if (!with_gradient) return true;
    // dL/dx: the embedding's transpose applied to dL/dp_i = 2 scale diff_i.
    const Eigen::Matrix3Xd dl_dx = EmbeddingTranspose(
        model_.embedding, model_.mesh.tets, (2.0 * LossScale()) * diff, static_cast<int>(x.cols()));
    std::string error;
    // A pose whose K needed a shift before starts from a hundredth of that shift (one
    // factorization as a rule, the shift decaying while K allows) instead of paying for
    // the exact attempt and the escapes again.
    const bool known_degenerate = adjoint_shift_[p] > 0.0;
    // (A test may make the exact adjoint fail here, to check the shifted one against
    // finite differences where both exist.)
    if (!known_degenerate && !FailurePoint("objective:exact_adjoint") &&
        w->differentiator->Prepare(x, a, &error) &&
        w->differentiator->LossGradient(dl_dx, dl_da, &error)) {
      break;
    }
    if (known_degenerate || escape == kMaxEscapes) {
      // Not positive definite even after leaving it (a singular or degenerate K, not a
      // saddle that a perturbation leaves): the regularized adjoint, with the smallest
      // shift that factorizes.
      bool shifted = false;
      double shift = known_degenerate ? std::max(kFirstAdjointShift, adjoint_shift_[p] / 100.0)
                                      : kFirstAdjointShift;
      for (; shift <= kLastAdjointShift; shift *= 100.0) {
        std::string shift_error;
        if (w->differentiator->PrepareShifted(x, a, shift, &shift_error) &&
            w->differentiator->LossGradient(dl_dx, dl_da, &shift_error)) {
          shifted = true;
          break;
        }
        if (error.empty()) error = shift_error;
      }
      if (shifted) {
        adjoint_shift_[p] = shift;
        ++counters->shifted_adjoints;
        break;
      }
      failures_[p] = "pose '" + model_.poses[p].name + "': " + error;
      return false;
    }
    ++counters->unstable_escapes;
    const FactorizationCounters escape_before = factorization.counters();
    const QuasistaticSolveReport again = w->solver->LeaveUnstableEquilibrium(
        kEscapeRelativeSize, 7919u * static_cast<unsigned>(p) + escape);
    CountSolve(again, counters);
    const FactorizationCounters& escape_after = factorization.counters();
    escape_factorizations += escape_after.factorizations - escape_before.factorizations;
    escape_reused += escape_after.reused_solves - escape_before.reused_solves;
    escape_indefinite += escape_after.indefinite_reuses - escape_before.indefinite_reuses;
    if (!again.converged) {
      failures_[p] = "pose '" + model_.poses[p].name + "': leaving an unstable equilibrium (" +
                     error + "): " + again.Summary();
      return false;
    }
  }
  if (options_.energy_regularization > 0.0) *dl_da += EnergyScale() * energy_da;
  const FactorizationCounters& after = factorization.counters();
  counters->adjoint_factorizations =
      after.factorizations - before.factorizations - escape_factorizations;
  counters->factorizations += counters->adjoint_factorizations;
  trace->reused = after.reused_solves - before.reused_solves - escape_reused;
  trace->indefinite = after.indefinite_reuses - before.indefinite_reuses - escape_indefinite;
  counters->reused_solves += trace->reused;
  counters->adjoint_seconds = adjoint_timer.Seconds();
  return true;
}

void EndToEndObjective::EvaluatePose(int k, int t, const ActuationMatrix& a,
                                     const PointOnLine* line, bool with_gradient,
                                     Eigen::Matrix3Xd* solved, ActuationMatrix* dl_da,
                                     Counters* counters) const {
  const int p = owned_[k];
  Worker& w = workers_[solver_per_pose_ ? k : t];
  StiffnessFactorization* factorization = w.solver->stiffness_factorization();
  const int cg_start = factorization->counters().cg_iterations;
  WallTimer solve_timer;
  const char* start_kind = StartPose(k, a, &w);  // for the per-pose trace (VLOG 2)
  if (line != nullptr &&
      StartOnLine(remembered_[line->from].states[p], remembered_[line->to].states[p], line->t,
                  states_[p], &w)) {
    ++counters->line_starts;
  }
  // (never with a solver per pose)
  const KeepFactorOnExit keep_factor(
      factorization, k < num_stored_factors_ ? &stored_factors_[k] : nullptr, &failures_[p]);
  const FactorizationCounters solve_before = factorization->counters();
  QuasistaticSolveReport report = w.solver->Solve();
  const FactorizationCounters& solve_after = factorization->counters();
  const int solve_failed_reuses = solve_after.failed_reuses - solve_before.failed_reuses;
  const int solve_indefinite = solve_after.indefinite_reuses - solve_before.indefinite_reuses;
  CountSolve(report, counters);
  if (!report.converged && !converged_once_[p]) {  // retry from rest
    ++counters->retries_from_rest;
    w.solver->SetPositions(model_.mesh.vertices);
    report = w.solver->Solve();
    CountSolve(report, counters);
  }
  counters->solve_seconds = solve_timer.Seconds();
  // The CG iterations of every evaluation (Newton steps by CG on an earlier factor too),
  // counted on every way out (they were counted only with a gradient).
  struct CountCg {
    ~CountCg() { counters->cg_iterations = factorization->counters().cg_iterations - start; }
    Counters* counters;
    const StiffnessFactorization* factorization;
    int start;
  } count_cg{counters, factorization, cg_start};
  if (!report.converged) {
    failures_[p] = "pose '" + model_.poses[p].name + "': " + report.Summary();
    return;
  }
  AdjointTrace adjoint;
  if (!PoseGradient(p, a, with_gradient, &w, solved, dl_da, counters, &adjoint) ||
      !with_gradient) {
    return;
  }
  counters->cg_iterations = factorization->counters().cg_iterations - cg_start;
  VLOG(2) << "  pose " << p << " '" << model_.poses[p].name << "': start " << start_kind
          << (counters->line_starts > 0 ? ", on the line" : "") << ", force "
          << report.initial_max_force << "; solve " << report.lbfgs_iterations
          << (report.lbfgs_stalled ? " L-BFGS (stalled), " : " L-BFGS, ")
          << report.newton_steps << " Newton (" << report.reused_steps << " by CG, "
          << report.projected_steps << " projected), " << report.factorizations
          << " factorizations (" << report.shifted_factorizations << " shifted), "
          << solve_failed_reuses << " failed CG (" << solve_indefinite
          << " indefinite); adjoint " << counters->adjoint_factorizations
          << " factorizations, " << adjoint.reused << " by CG, " << adjoint.indefinite
          << " indefinite by CG; " << counters->cg_iterations << " CG iterations; "
          << report.seconds << " + " << counters->adjoint_seconds << " s"
          << (counters->unstable_escapes > 0 ? ", escaped an unstable equilibrium" : "");
}

void EndToEndObjective::GatherPoseErrorsToRoot() const {
  // Each is non-zero on its owner only, so the sums are exact.
  std::vector<double> per_pose(3 * num_poses_, 0.0);
  for (int p : owned_) {
    per_pose[p] = pose_loss_[p];
    per_pose[num_poses_ + p] = pose_mean_[p];
    per_pose[2 * num_poses_ + p] = pose_max_[p];
  }
  communicator_->SumToRoot(per_pose.data(), 3 * num_poses_);
  if (rank_ != 0) return;
  for (int p = 0; p < num_poses_; ++p) {
    pose_loss_[p] = per_pose[p];
    pose_mean_[p] = per_pose[num_poses_ + p];
    pose_max_[p] = per_pose[2 * num_poses_ + p];
  }
}

void EndToEndObjective::BackPropagate(const double* parameters, const DecoderWorkspace& workspace,
                                      const std::vector<ActuationMatrix>& dl_da,
                                      double* gradient) const {
  Eigen::Map<Eigen::VectorXd> g(gradient, NumParameters());
  g.setZero();
  Eigen::Map<Eigen::MatrixXd> g_latents(gradient + num_params_, latent_dim_, num_poses_);
  const int num_owned = static_cast<int>(owned_.size());
  if (num_owned > 0) {
    Eigen::MatrixXd latent_gradient;
    model_.decoder->Backward(parameters, workspace, dl_da, gradient, &latent_gradient);
    for (int k = 0; k < num_owned; ++k) g_latents.col(owned_[k]) = latent_gradient.col(k);
  }
  // The decoder parameters' gradient summed over ranks; each latent's comes from the
  // rank that owns its pose (the others add zeros).
  if (distributed()) communicator_->SumToRoot(gradient, NumParameters());
  const Eigen::Map<const Eigen::MatrixXd> latents(parameters + num_params_, latent_dim_,
                                                  num_poses_);
  const Eigen::Map<const Eigen::VectorXd> decoder_params(parameters, num_params_);
  g_latents += (2.0 * options_.latent_regularization / num_poses_) * latents;
  g.head(num_params_) += (2.0 * options_.decoder_regularization) * decoder_params;
}

bool EndToEndObjective::EvaluateHere(const double* parameters, double* cost,
                                     double* gradient) const {
  WallTimer evaluation_timer;
  const Eigen::Map<const Eigen::MatrixXd> latents(parameters + num_params_, latent_dim_,
                                                  num_poses_);
  const int num_owned = static_cast<int>(owned_.size());
  Eigen::MatrixXd owned_latents(latent_dim_, num_owned);
  for (int k = 0; k < num_owned; ++k) owned_latents.col(k) = latents.col(owned_[k]);
  std::vector<ActuationMatrix> a;
  DecoderWorkspace workspace;
  if (num_owned > 0) model_.decoder->DecodeBatch(parameters, owned_latents, &a, &workspace);
  double decoder_seconds = evaluation_timer.Seconds();
  std::vector<ActuationMatrix> dl_da(num_owned);
  std::vector<Counters> pose_counters(num_owned);
  // The equilibria found; they become the warm starts only if the whole evaluation
  // succeeds (a failed line-search trial must not move any pose's warm start).
  std::vector<Eigen::Matrix3Xd> solved(num_owned);
  // A line-search trial between (or beyond) two remembered evaluations: their
  // equilibria, interpolated, are a candidate start for every pose.
  PointOnLine line;
  bool on_line = false;
  const int num_remembered = static_cast<int>(remembered_.size());  // before this one's
  if (options_.line_search_starts) {
    std::vector<const Eigen::VectorXd*> points;
    for (const Remembered& r : remembered_) points.push_back(&r.parameters);
    on_line = FindPointOnLine(points, parameters, &line);
  }
  const int threads = std::max(1, std::min(options_.num_threads, num_owned));
  // Once a pose has failed, the evaluation fails whatever the others give (and no warm
  // start moves): the poses not yet begun are skipped.
  for (int p : owned_) failures_[p].clear();
  std::atomic<bool> failed{false};
  ParallelFor(threads, 0, num_owned, [&](int t, int k) {
    if (failed.load()) return;
    EvaluatePose(k, t, a[k], on_line ? &line : nullptr, gradient != nullptr, &solved[k],
                 &dl_da[k], &pose_counters[k]);
    if (!failures_[owned_[k]].empty()) failed.store(true);
  }, 1);
  FaultPoint("objective:solved");
  Counters total;
  for (const Counters& c : pose_counters) total.Add(c);
  // The first failing pose (in pose order, as in one process), over all ranks.
  int first_failure = num_poses_;
  for (int p : owned_) {
    if (!failures_[p].empty()) {
      first_failure = p;
      break;
    }
  }
  if (distributed()) {
    communicator_->MinToAll(&first_failure, 1);
    SumCountersToRoot(*communicator_, &total);
  }
  total.evaluations = 1;
  total.decoder_seconds = decoder_seconds;
  if (first_failure < num_poses_) {
    std::string failure = failures_[first_failure];
    if (distributed()) communicator_->BroadcastText(&failure, first_failure % size_);
    last_failure_ = failure;
    total.seconds = evaluation_timer.Seconds();
    last_counters_ = total;
    total_counters_.Add(total);  // a failed evaluation costs too
    if (rank_ == 0) {
      VLOG(1) << "evaluation " << total_counters_.evaluations << " failed after "
              << total.seconds << " s, " << total.factorizations / double(num_poses_)
              << " factorizations per pose: " << failure;
    }
    return false;
  }
  if (distributed()) GatherPoseErrorsToRoot();
  double data = 0;
  for (double l : pose_loss_) data += l;
  const Eigen::Map<const Eigen::VectorXd> decoder_params(parameters, num_params_);
  *cost = data + options_.latent_regularization * latents.squaredNorm() / num_poses_ +
          options_.decoder_regularization * decoder_params.squaredNorm();
  // Rank 0's loss on every rank, so that all take the same decisions below.
  double loss = *cost;
  if (distributed()) communicator_->Broadcast(&loss, 1, 0);
  if (!std::isfinite(loss)) {
    // A failed evaluation: the warm starts and remembered evaluations stay as they were.
    last_failure_ = "the loss is not finite (" + std::to_string(loss) +
                    "): a latent, a decoder parameter or a pose surface is not finite?";
    total.seconds = evaluation_timer.Seconds();
    last_counters_ = total;
    total_counters_.Add(total);
    return false;
  }
  for (int k = 0; k < num_owned; ++k) {
    states_[owned_[k]] = std::move(solved[k]);
    if (solver_per_pose_ || k < num_stored_factors_) state_actuations_[owned_[k]] = a[k];
  }
  if (static_cast<int>(remembered_.size()) == kRememberedEvaluations) {
    remembered_.erase(remembered_.begin());
  }
  remembered_.push_back({Eigen::Map<const Eigen::VectorXd>(parameters, NumParameters()),
                         states_, mean_surface_error(), max_surface_error()});
  // The lowest loss since the last kept point: what a line search accepts, though it
  // may have evaluated more trial points since than are remembered.
  if (loss < best_loss_) {
    best_loss_ = loss;
    best_ = remembered_.back();
  }
  if (gradient != nullptr) {
    WallTimer backward_timer;
    BackPropagate(parameters, workspace, dl_da, gradient);
    decoder_seconds += backward_timer.Seconds();
  }
  total.decoder_seconds = decoder_seconds;
  total.seconds = evaluation_timer.Seconds();
  last_counters_ = total;
  total_counters_.Add(total);
  if (rank_ == 0 && VLOG_IS_ON(1)) {
    const double per_pose = 1.0 / num_poses_;
    char text[320];
    std::snprintf(text, sizeof(text),
                  "evaluation %d%s: loss %.9e; per pose %.2f factorizations, %.2f Newton steps, "
                  "%.1f CG iterations; %.1f s",
                  total_counters_.evaluations, gradient != nullptr ? " with gradient" : "", *cost,
                  total.factorizations * per_pose, total.newton_steps * per_pose,
                  total.cg_iterations * per_pose, total.seconds);
    VLOG(1) << text;
    if (on_line) {
      VLOG(1) << "  a line-search trial at t = " << line.t << " on the line from the "
              << num_remembered - line.from << "-th to the " << num_remembered - line.to
              << "-th successful evaluation before it: " << total.line_starts << " of "
              << num_poses_ << " poses started on the line";
    }
  }
  return true;
}

}  // namespace aqs
