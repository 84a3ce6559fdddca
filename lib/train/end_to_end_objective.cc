#include "train/end_to_end_objective.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include <glog/logging.h>

#include "diff/actuation_force_products.h"
#include "geometry/embedding.h"
#include "train/line_search_start.h"
#include "util/fault_injection.h"
#include "util/parallel_for.h"

namespace aqs {

EndToEndObjective::EndToEndObjective(const TrainOptions& options, const ActiveModel& model)
    : options_(options),
      model_(model),
      communicator_(options.communicator),
      physics_(model.mesh, model.mu),
      num_params_(model.decoder->num_parameters()),
      latent_dim_(model.decoder->latent_dim()),
      num_poses_(model.num_poses()),
      states_(model.states) {
  states_.resize(num_poses_);
  for (Eigen::Matrix3Xd& state : states_) {
    if (state.cols() == 0) state = model.mesh.vertices;
  }
  for (int p = 0; p < num_poses_; ++p) {
    fixed_positions_.push_back(PoseBoundaryConditions(model_, p).positions);
  }
  if (communicator_ != nullptr) {
    rank_ = communicator_->rank();
    size_ = communicator_->size();
  }
  owned_ = OwnedIndices(num_poses_, rank_, size_);
  state_actuations_.resize(num_poses_);
  pose_loss_.resize(num_poses_);
  pose_mean_.resize(num_poses_);
  pose_max_.resize(num_poses_);
  failures_.resize(num_poses_);
  converged_once_.assign(num_poses_, 0);
  adjoint_shift_.assign(num_poses_, 0.0);
  const int num_owned = static_cast<int>(owned_.size());
  if (num_owned == 0) return;  // a spare rank: no solver
  QuasistaticSolverOptions solver_options = options.solver;
  solver_options.num_threads = 1;
  const BoundaryConditions bc = PoseBoundaryConditions(model_, 0);
  // One solver per pose if all their factors fit the budget: the first solver's
  // symbolic analysis gives the factor's size.
  auto first = std::make_unique<QuasistaticSolver>(physics_, bc, solver_options);
  first->stiffness_factorization()->Analyze();
  // A solver's factor and its element SVD cache (physics/polar_cache.h). A solver per
  // pose preconditions its L-BFGS phase with its own earlier factor
  // (lbfgs_reuses_factor, below); before, each built a second factor for it (at 232,635
  // elements the per-pose layout measured 0.8 GB per pose against 0.27 GB per factor).
  factor_gb_ = (first->stiffness_factorization()->cholesky().factor_bytes() +
                PolarCache::BytesFor(physics_.num_vertices(), physics_.num_elements())) /
               1e9;
  // (The budget is per process; the choice also depends on the pose count in all, so
  // that a rank owning one pose of many keeps its factor as one process would.)
  solver_per_pose_ = num_poses_ > 1 && factor_gb_ * num_owned <= options.max_factor_cache_gb;
  // Otherwise the budget keeps single-precision copies of the first poses' factors.
  stored_factor_gb_ = first->stiffness_factorization()->cholesky().stored_factor_bytes() / 1e9;
  if (!solver_per_pose_ && num_poses_ > 1 && stored_factor_gb_ > 0.0) {
    num_stored_factors_ = static_cast<int>(std::min<double>(
        num_owned, std::floor(options.max_factor_cache_gb / stored_factor_gb_)));
    stored_factors_.resize(num_stored_factors_);
  }
  // A factor of another pose is a poor preconditioner: with shared solvers a pose's
  // solve starts by factorizing (StiffnessFactorization::RequestRefresh in Evaluate)
  // unless its own stored factor is restored, and its later Newton steps and its adjoint
  // reuse that factor by CG. A pose's own earlier factor preconditions L-BFGS too.
  // (Solvers per thread choose it per solve: for the poses whose stored factor is
  // restored.)
  solver_options.lbfgs_reuses_factor = solver_per_pose_;
  first->set_options(solver_options);
  EquilibriumDifferentiatorOptions differentiator_options;
  differentiator_options.num_threads = 1;
  differentiator_options.reuse = {20, options.adjoint_tolerance, 6, 1e-2, 1, 8};
  workers_.resize(solver_per_pose_ ? num_owned : std::max(1, std::min(options.num_threads, num_owned)));
  for (size_t i = 0; i < workers_.size(); ++i) {
    Worker& w = workers_[i];
    w.solver = i == 0 ? std::move(first)
                      : std::make_unique<QuasistaticSolver>(physics_, bc, solver_options);
    w.differentiator = std::make_unique<EquilibriumDifferentiator>(
        w.solver->stiffness_factorization(), differentiator_options);
  }
}

EndToEndObjective::~EndToEndObjective() { StopWorkers(false); }

void EndToEndObjective::SendCommand(Command command, const double* parameters, int value) const {
  CHECK_EQ(rank_, 0) << "only rank 0 commands";
  int message[2] = {command, value};
  communicator_->Broadcast(message, 2, 0);
  if (command == kEvaluate || command == kEvaluateWithGradient || command == kUseStatesOf ||
      command == kCollectStates || command == kRefitLatents) {
    // Rank 0's buffer is only read.
    communicator_->Broadcast(const_cast<double*>(parameters), NumParameters(), 0);
  }
}

void EndToEndObjective::StopWorkers(bool ok) {
  if (!distributed() || rank_ != 0 || stopped_) return;
  stopped_ = true;
  SendCommand(kStop, nullptr, ok ? 1 : 0);
}

bool EndToEndObjective::Serve(ActiveModel* model) {
  CHECK_NE(rank_, 0) << "rank 0 drives; the others serve";
  Eigen::VectorXd parameters(NumParameters());
  Eigen::VectorXd gradient(NumParameters());
  std::vector<Eigen::Matrix3Xd> unused;
  for (;;) {
    int message[2] = {0, 0};
    communicator_->Broadcast(message, 2, 0);
    const Command command = static_cast<Command>(message[0]);
    if (command == kStop) return message[1] != 0;
    if (command == kAllowRetryFromRest) {
      converged_once_.assign(num_poses_, 0);
      adjoint_shift_.assign(num_poses_, 0.0);
      continue;
    }
    if (command == kKeepStates) {
      KeepRemembered(message[1]);
      continue;
    }
    communicator_->Broadcast(parameters.data(), NumParameters(), 0);
    double cost = 0;
    switch (command) {
      case kEvaluate:
        EvaluateHere(parameters.data(), &cost, nullptr);
        break;
      case kEvaluateWithGradient:
        EvaluateHere(parameters.data(), &cost, gradient.data());
        break;
      case kUseStatesOf:
        UseStatesOf(parameters.data());
        break;
      case kCollectStates:
        CollectStatesHere(parameters.data(), &unused);
        break;
      case kRefitLatents:
        CHECK(model != nullptr) << "latent refits need Serve(model)";
        RefitHere(model, parameters.data());
        break;
      default:
        LOG(FATAL) << "unknown command " << message[0] << " from rank 0";
    }
  }
}

void EndToEndObjective::AllowRetryFromRest() {
  if (distributed() && rank_ == 0) SendCommand(kAllowRetryFromRest, nullptr);
  converged_once_.assign(num_poses_, 0);
  adjoint_shift_.assign(num_poses_, 0.0);
}

int EndToEndObjective::NumParameters() const { return num_params_ + latent_dim_ * num_poses_; }

Eigen::VectorXd EndToEndObjective::ModelParameters() const {
  Eigen::VectorXd parameters(NumParameters());
  parameters.head(num_params_) = model_.decoder_params;
  Eigen::Map<Eigen::MatrixXd>(parameters.data() + num_params_, latent_dim_, num_poses_) =
      model_.latents;
  return parameters;
}

double EndToEndObjective::mean_surface_error() const {
  double mean = 0;
  for (double m : pose_mean_) mean += m / num_poses_;
  return mean;
}

double EndToEndObjective::max_surface_error() const {
  double worst = 0;
  for (double m : pose_max_) worst = std::max(worst, m);
  return worst;
}

bool EndToEndObjective::IsAt(const Remembered& evaluation, const double* parameters) const {
  // Bit for bit: the point a line search accepted is one it evaluated.
  const size_t bytes = sizeof(double) * static_cast<size_t>(NumParameters());
  return evaluation.parameters.size() == NumParameters() &&
         std::memcmp(evaluation.parameters.data(), parameters, bytes) == 0;
}

int EndToEndObjective::RememberedIndex(const double* parameters) const {
  for (int i = static_cast<int>(remembered_.size()) - 1; i >= 0; --i) {
    if (IsAt(remembered_[i], parameters)) return i;
  }
  return -1;
}

bool EndToEndObjective::StatesAt(const double* parameters,
                                 std::vector<Eigen::Matrix3Xd>* states) const {
  // The kept point first: a line search that finds no decrease ends where it started,
  // and Ceres may evaluate that point again from a trial point's equilibria, which can
  // be another equilibrium (with another loss) than the one that was accepted.
  if (IsAt(kept_, parameters)) {
    *states = kept_.states;
    return true;
  }
  const int index = RememberedIndex(parameters);
  if (index < 0) return false;
  *states = remembered_[index].states;
  return true;
}

bool EndToEndObjective::KeepStatesOf(const double* parameters) {
  CHECK_EQ(rank_, 0) << "only rank 0 commands";
  int index = RememberedIndex(parameters);
  if (index < 0) {
    if (!IsAt(best_, parameters)) return false;
    index = kKeepBest;
  }
  if (distributed()) SendCommand(kKeepStates, nullptr, index);
  KeepRemembered(index);
  return true;
}

void EndToEndObjective::KeepRemembered(int index) {
  if (index == kKeepBest) {
    kept_ = best_;
  } else {
    CHECK(index >= 0 && index < static_cast<int>(remembered_.size()))
        << "no remembered evaluation " << index << " on rank " << rank_;
    kept_ = remembered_[index];
  }
  best_ = Remembered();
  best_loss_ = std::numeric_limits<double>::infinity();
}

bool EndToEndObjective::UseStatesOf(const double* parameters) {
  if (distributed() && rank_ == 0) SendCommand(kUseStatesOf, parameters);
  // The states' actuations are not remembered: no prediction from them.
  for (ActuationMatrix& a : state_actuations_) a.resize(6, 0);
  return StatesAt(parameters, &states_);
}

LatentRefitReport EndToEndObjective::RefitLatents(ActiveModel* model, double* parameters) {
  if (distributed()) SendCommand(kRefitLatents, parameters);
  return RefitHere(model, parameters);
}

LatentRefitReport EndToEndObjective::RefitHere(ActiveModel* model, double* parameters) {
  WallTimer timer;
  const Eigen::Map<const Eigen::VectorXd> decoder_params(parameters, num_params_);
  Eigen::Map<Eigen::MatrixXd> latents(parameters + num_params_, latent_dim_, num_poses_);
  model->decoder_params = decoder_params;
  model->latents = latents;
  std::vector<Eigen::Matrix3Xd> at;
  if (!StatesAt(parameters, &at)) at = states_;
  model->states.resize(num_poses_);
  for (int p : owned_) model->states[p] = at[p];
  LatentRefitOptions refit;
  refit.latent_regularization = options_.latent_regularization;
  refit.max_iterations = options_.latent_refit_iterations;
  refit.solver = options_.solver;
  refit.num_threads = options_.num_threads;
  LatentRefitReport report = RefitTrainingLatents(refit, model, &owned_);
  for (int p : owned_) states_[p] = model->states[p];
  // The states' actuations changed with the latents: no prediction from the old ones.
  for (ActuationMatrix& a : state_actuations_) a.resize(6, 0);
  if (distributed()) {
    // Each latent from the rank that owns its pose (the others add zeros), and the
    // reports' sums.
    Eigen::MatrixXd owned_latents = Eigen::MatrixXd::Zero(latent_dim_, num_poses_);
    for (int p : owned_) owned_latents.col(p) = model->latents.col(p);
    communicator_->SumToRoot(owned_latents.data(), static_cast<int>(owned_latents.size()));
    double sums[4] = {report.loss_before, report.loss_after, double(report.improved),
                      double(report.failed)};
    communicator_->SumToRoot(sums, 4);
    if (rank_ == 0) {
      model->latents = owned_latents;
      report.loss_before = sums[0];
      report.loss_after = sums[1];
      report.improved = static_cast<int>(sums[2]);
      report.failed = static_cast<int>(sums[3]);
    }
  }
  if (rank_ == 0) latents = model->latents;
  report.seconds = timer.Seconds();
  return report;
}

void EndToEndObjective::CollectStates(const double* parameters,
                                      std::vector<Eigen::Matrix3Xd>* states) const {
  if (distributed()) SendCommand(kCollectStates, parameters);
  CollectStatesHere(parameters, states);
}

void EndToEndObjective::CollectStatesHere(const double* parameters,
                                          std::vector<Eigen::Matrix3Xd>* states) const {
  if (!StatesAt(parameters, states)) *states = states_;
  if (!distributed()) return;
  // Every rank sends its own poses' states (3 x vertices each, in pose order); rank 0
  // puts them in place. A pose without a state (never converged) is sent as the rest
  // shape's size of NaN and comes back empty.
  const int nv = model_.mesh.num_vertices();
  const int block = 3 * nv;
  std::vector<double> send;
  send.reserve(owned_.size() * block);
  for (int p : owned_) {
    const Eigen::Matrix3Xd& x = (*states)[p];
    if (x.cols() == nv) {
      send.insert(send.end(), x.data(), x.data() + block);
    } else {
      send.insert(send.end(), block, std::numeric_limits<double>::quiet_NaN());
    }
  }
  std::vector<int> counts(size_);
  for (int r = 0; r < size_; ++r) {
    counts[r] = block * static_cast<int>(OwnedIndices(num_poses_, r, size_).size());
  }
  std::vector<double> received(rank_ == 0 ? static_cast<size_t>(block) * num_poses_ : 0);
  communicator_->GatherToRoot(send.data(), counts, received.data());
  if (rank_ != 0) return;
  states->assign(num_poses_, Eigen::Matrix3Xd());
  size_t offset = 0;
  for (int r = 0; r < size_; ++r) {
    for (int p : OwnedIndices(num_poses_, r, size_)) {
      const Eigen::Map<const Eigen::Matrix3Xd> x(received.data() + offset, 3, nv);
      offset += block;
      if (x.allFinite()) (*states)[p] = x;
    }
  }
}

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
  // With the last evaluation at one end E (the other O), the start already there is E's
  // first-order prediction E + delta; the quadratic in the line's coordinate (tau = 0 at
  // O, 1 at E) through O and E with E's predicted slope gives E + tau delta + (1 - tau)^2
  // (O - E).
  const bool last_is_to = last.cols() == nv && (to.array() == last.array()).all();
  const bool last_is_from = last.cols() == nv && !last_is_to && (from.array() == last.array()).all();
  if (last_is_to || last_is_from) {
    const Eigen::Matrix3Xd& e = last_is_to ? to : from;
    const Eigen::Matrix3Xd& o = last_is_to ? from : to;
    const double tau = last_is_to ? t : 1.0 - t;
    consider(e + tau * (start - e) + (1.0 - tau) * (1.0 - tau) * (o - e));
  }
  worker->solver->SetPositions(chosen.cols() == nv ? chosen : start);
  return chosen.cols() == nv;
}

bool EndToEndObjective::Evaluate(const double* parameters, double* cost, double* gradient) const {
  if (deadline_ > 0.0 && timer_.Seconds() > deadline_) {
    last_failure_ = "the time limit has passed";
    return false;
  }
  if (distributed()) {
    SendCommand(gradient != nullptr ? kEvaluateWithGradient : kEvaluate, parameters);
  }
  return EvaluateHere(parameters, cost, gradient);
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
  const int n = model_.num_surface_vertices();
  const double scale = 1.0 / (static_cast<double>(num_poses_) * n);
  // (1/P) E / sum_e mu_e V_e: the energy regularizer's factor.
  const double energy_scale = options_.energy_regularization /
                              (static_cast<double>(num_poses_) * physics_.stiffness_volume());
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
    const int p = owned_[k];
    struct FlagFailure {
      const std::string* failure;
      std::atomic<bool>* failed;
      ~FlagFailure() {
        if (!failure->empty()) failed->store(true);
      }
    } flag_failure{&failures_[p], &failed};
    Worker& w = workers_[solver_per_pose_ ? k : t];
    Counters& counters = pose_counters[k];
    const int cg_start = w.solver->stiffness_factorization()->counters().cg_iterations;
    WallTimer solve_timer;
    w.solver->SetFixedPositions(fixed_positions_[p]);
    w.solver->actuation() = a[k];
    w.solver->SetPositions(states_[p]);
    const bool stored = k < num_stored_factors_;  // (never with a solver per pose)
    // For the per-pose trace (VLOG 2): how the solve started.
    const char* start_kind = "own factor";
    if (solver_per_pose_) {
      PredictState(p, &w);
    } else {
      const bool restored =
          stored && w.solver->stiffness_factorization()->RestoreFactor(stored_factors_[k]);
      if (restored) {
        start_kind = w.solver->stiffness_factorization()->refresh_requested() ? "stored aged"
                                                                              : "stored";
        PredictState(p, &w);
      } else {
        start_kind = "no factor";
        w.solver->stiffness_factorization()->RequestRefresh();  // the factor is another pose's
      }
      // The pose's own earlier factor preconditions L-BFGS; without one, the thread's
      // rotation-fixed factor (kept between solves) does.
      QuasistaticSolverOptions solver_options = w.solver->options();
      solver_options.lbfgs_reuses_factor = restored;
      w.solver->set_options(solver_options);
    }
    if (on_line && StartOnLine(remembered_[line.from].states[p], remembered_[line.to].states[p],
                               line.t, states_[p], &w)) {
      ++counters.line_starts;
    }
    // Whatever the outcome, the factor held at the end is the pose's to keep (none after
    // a failure: it may belong to a state far from the next evaluation's).
    struct KeepFactor {
      StiffnessFactorization* factorization;
      StoredStiffnessFactor* stored;
      const std::string* failure;
      ~KeepFactor() {
        if (stored == nullptr) return;
        if (failure->empty() && factorization->factor_rounded()) {
          stored->aged = factorization->refresh_requested();  // the values are those restored
        } else if (failure->empty()) {
          factorization->StoreFactor(stored);
        } else {
          stored->factor.Clear();
        }
      }
    } keep_factor{w.solver->stiffness_factorization(), stored ? &stored_factors_[k] : nullptr,
                  &failures_[p]};
    const FactorizationCounters solve_before = w.solver->stiffness_factorization()->counters();
    QuasistaticSolveReport report = w.solver->Solve();
    const FactorizationCounters& solve_after = w.solver->stiffness_factorization()->counters();
    const int solve_failed_reuses = solve_after.failed_reuses - solve_before.failed_reuses;
    const int solve_indefinite = solve_after.indefinite_reuses - solve_before.indefinite_reuses;
    auto count = [&counters](const QuasistaticSolveReport& r) {
      counters.factorizations += r.factorizations;
      counters.reused_solves += r.reused_steps;
      counters.lbfgs_iterations += r.lbfgs_iterations;
      counters.newton_steps += r.newton_steps;
    };
    count(report);
    if (!report.converged && !converged_once_[p]) {  // retry from rest
      ++counters.retries_from_rest;
      w.solver->SetPositions(model_.mesh.vertices);
      report = w.solver->Solve();
      count(report);
    }
    counters.solve_seconds = solve_timer.Seconds();
    if (!report.converged) {
      failures_[p] = "pose '" + model_.poses[p].name + "': " + report.Summary();
      return;
    }
    WallTimer adjoint_timer;
    StiffnessFactorization& factorization = *w.solver->stiffness_factorization();
    const FactorizationCounters before = factorization.counters();
    // The escapes' solves, counted there.
    int escape_factorizations = 0, escape_reused = 0, escape_indefinite = 0;
    ActuationMatrix energy_da;  // dE/da at the equilibrium (energy_regularization)
    // An equilibrium whose exact stiffness is not positive definite is unstable (a
    // saddle of the energy): the adjoint cannot use it and the pose would not stay
    // there. Leave it by a small perturbation and solve again, at most kMaxEscapes times.
    for (int escape = 0;; ++escape) {
      solved[k] = w.solver->positions();
      const Eigen::Matrix3Xd& x = solved[k];
      converged_once_[p] = 1;
      const Eigen::Matrix3Xd diff =
          EmbeddedPositions(model_.embedding, model_.mesh.tets, x) - model_.poses[p].surface;
      pose_loss_[p] = diff.squaredNorm() * scale;
      if (options_.energy_regularization > 0.0) {
        // The equilibrium-energy regularizer (TrainOptions::energy_regularization); its
        // gradient dE/da at fixed x is the total one at an equilibrium. The element SVDs
        // are those of the solve's last energy evaluation, at x as a rule.
        const double energy = physics_.EnergyActuationGradient(
            x, a[k], &energy_da, 1, &w.solver->stiffness_factorization()->polar_cache());
        pose_loss_[p] += energy_scale * energy;
      }
      const Eigen::VectorXd distance = diff.colwise().norm();
      pose_mean_[p] = distance.mean();
      pose_max_[p] = distance.maxCoeff();
      if (gradient == nullptr) return;
      // dL/dx: the embedding's transpose applied to dL/dp_i = 2 scale diff_i.
      const Eigen::Matrix3Xd dl_dx = EmbeddingTranspose(model_.embedding, model_.mesh.tets,
                                                        (2.0 * scale) * diff,
                                                        static_cast<int>(x.cols()));
      std::string error;
      // A pose whose K needed a shift before starts from a hundredth of that shift (one
      // factorization as a rule, the shift decaying while K allows) instead of paying for
      // the exact attempt and the escapes again.
      const bool known_degenerate = adjoint_shift_[p] > 0.0;
      if (!known_degenerate && w.differentiator->Prepare(x, a[k], &error) &&
          w.differentiator->LossGradient(dl_dx, &dl_da[k], &error)) {
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
          if (w.differentiator->PrepareShifted(x, a[k], shift, &shift_error) &&
              w.differentiator->LossGradient(dl_dx, &dl_da[k], &shift_error)) {
            shifted = true;
            break;
          }
          if (error.empty()) error = shift_error;
        }
        if (shifted) {
          adjoint_shift_[p] = shift;
          ++counters.shifted_adjoints;
          break;
        }
        failures_[p] = "pose '" + model_.poses[p].name + "': " + error;
        return;
      }
      ++counters.unstable_escapes;
      const FactorizationCounters escape_before = factorization.counters();
      const QuasistaticSolveReport again = w.solver->LeaveUnstableEquilibrium(
          kEscapeRelativeSize, 7919u * static_cast<unsigned>(p) + escape);
      count(again);
      escape_factorizations += factorization.counters().factorizations - escape_before.factorizations;
      escape_reused += factorization.counters().reused_solves - escape_before.reused_solves;
      escape_indefinite +=
          factorization.counters().indefinite_reuses - escape_before.indefinite_reuses;
      if (!again.converged) {
        failures_[p] = "pose '" + model_.poses[p].name + "': leaving an unstable equilibrium (" +
                       error + "): " + again.Summary();
        return;
      }
    }
    if (options_.energy_regularization > 0.0) dl_da[k] += energy_scale * energy_da;
    const FactorizationCounters& after = factorization.counters();
    counters.adjoint_factorizations =
        after.factorizations - before.factorizations - escape_factorizations;
    counters.factorizations += counters.adjoint_factorizations;
    const int adjoint_reused = after.reused_solves - before.reused_solves - escape_reused;
    const int adjoint_indefinite =
        after.indefinite_reuses - before.indefinite_reuses - escape_indefinite;
    counters.reused_solves += adjoint_reused;
    counters.adjoint_seconds = adjoint_timer.Seconds();
    counters.cg_iterations = after.cg_iterations - cg_start;
    VLOG(2) << "  pose " << p << " '" << model_.poses[p].name << "': start " << start_kind
            << (counters.line_starts > 0 ? ", on the line" : "") << ", force "
            << report.initial_max_force << "; solve " << report.lbfgs_iterations
            << (report.lbfgs_stalled ? " L-BFGS (stalled), " : " L-BFGS, ")
            << report.newton_steps << " Newton (" << report.reused_steps
            << " by CG, " << report.projected_steps << " projected), "
            << report.factorizations << " factorizations (" << report.shifted_factorizations
            << " shifted), " << solve_failed_reuses << " failed CG (" << solve_indefinite
            << " indefinite); adjoint "
            << counters.adjoint_factorizations << " factorizations, " << adjoint_reused
            << " by CG, " << adjoint_indefinite << " indefinite by CG; "
            << counters.cg_iterations << " CG iterations; " << report.seconds << " + "
            << counters.adjoint_seconds << " s"
            << (counters.unstable_escapes > 0 ? ", escaped an unstable equilibrium" : "");
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
    double sums[12] = {double(total.factorizations), double(total.adjoint_factorizations),
                      double(total.reused_solves),  double(total.cg_iterations),
                      double(total.lbfgs_iterations), double(total.newton_steps),
                      double(total.retries_from_rest), total.solve_seconds,
                      total.adjoint_seconds, double(total.unstable_escapes),
                      double(total.shifted_adjoints), double(total.line_starts)};
    communicator_->SumToRoot(sums, 12);
    total.factorizations = static_cast<int>(sums[0]);
    total.adjoint_factorizations = static_cast<int>(sums[1]);
    total.reused_solves = static_cast<int>(sums[2]);
    total.cg_iterations = static_cast<int>(sums[3]);
    total.lbfgs_iterations = static_cast<int>(sums[4]);
    total.newton_steps = static_cast<int>(sums[5]);
    total.retries_from_rest = static_cast<int>(sums[6]);
    total.solve_seconds = sums[7];
    total.adjoint_seconds = sums[8];
    total.unstable_escapes = static_cast<int>(sums[9]);
    total.shifted_adjoints = static_cast<int>(sums[10]);
    total.line_starts = static_cast<int>(sums[11]);
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
  for (int k = 0; k < num_owned; ++k) {
    states_[owned_[k]] = std::move(solved[k]);
    if (solver_per_pose_ || k < num_stored_factors_) state_actuations_[owned_[k]] = a[k];
  }
  if (static_cast<int>(remembered_.size()) == kRememberedEvaluations) {
    remembered_.erase(remembered_.begin());
  }
  remembered_.push_back(
      {Eigen::Map<const Eigen::VectorXd>(parameters, NumParameters()), states_});
  if (distributed()) {
    // Per pose loss, mean and max error on rank 0: each is non-zero on its owner only,
    // so the sums are exact.
    std::vector<double> per_pose(3 * num_poses_, 0.0);
    for (int p : owned_) {
      per_pose[p] = pose_loss_[p];
      per_pose[num_poses_ + p] = pose_mean_[p];
      per_pose[2 * num_poses_ + p] = pose_max_[p];
    }
    communicator_->SumToRoot(per_pose.data(), 3 * num_poses_);
    if (rank_ == 0) {
      for (int p = 0; p < num_poses_; ++p) {
        pose_loss_[p] = per_pose[p];
        pose_mean_[p] = per_pose[num_poses_ + p];
        pose_max_[p] = per_pose[2 * num_poses_ + p];
      }
    }
  }
  double data = 0;
  for (double l : pose_loss_) data += l;
  const Eigen::Map<const Eigen::VectorXd> decoder_params(parameters, num_params_);
  *cost = data + options_.latent_regularization * latents.squaredNorm() / num_poses_ +
          options_.decoder_regularization * decoder_params.squaredNorm();
  // The lowest loss since the last kept point: what a line search accepts, though it
  // may have evaluated more trial points since than are remembered (rank 0's loss on
  // every rank, so that all keep the same evaluation).
  double loss = *cost;
  if (distributed()) communicator_->Broadcast(&loss, 1, 0);
  if (loss < best_loss_) {
    best_loss_ = loss;
    best_ = remembered_.back();
  }
  if (gradient != nullptr) {
    WallTimer backward_timer;
    Eigen::Map<Eigen::VectorXd> g(gradient, NumParameters());
    g.setZero();
    Eigen::Map<Eigen::MatrixXd> g_latents(gradient + num_params_, latent_dim_, num_poses_);
    if (num_owned > 0) {
      Eigen::MatrixXd latent_gradient;
      model_.decoder->Backward(parameters, workspace, dl_da, gradient, &latent_gradient);
      for (int k = 0; k < num_owned; ++k) g_latents.col(owned_[k]) = latent_gradient.col(k);
    }
    // The decoder parameters' gradient summed over ranks; each latent's comes from the
    // rank that owns its pose (the others add zeros).
    if (distributed()) communicator_->SumToRoot(gradient, NumParameters());
    g_latents += (2.0 * options_.latent_regularization / num_poses_) * latents;
    g.head(num_params_) += (2.0 * options_.decoder_regularization) * decoder_params;
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
  if (!std::isfinite(*cost)) {
    last_failure_ = "the loss is not finite (" + std::to_string(*cost) +
                    "): a latent, a decoder parameter or a pose surface is not finite?";
    return false;
  }
  return true;
}

}  // namespace aqs
