#include "train/end_to_end_objective.h"

#include <algorithm>
#include <cstring>
#include <limits>

#include <glog/logging.h>

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
  // (If the analysis fails, the sizes read 0 and the first solve reports the failure.)
  first->stiffness_factorization()->Analyze();
  // A solver's factor and its element SVD cache (physics/polar_cache.h). A solver per
  // pose preconditions its L-BFGS phase with its own earlier factor
  // (lbfgs_reuses_factor, below); before, each built a second factor for it (at 232,635
  // elements the per-pose layout measured 0.8 GB per pose against 0.27 GB per factor).
  factor_gb_ = (first->stiffness_factorization()->cholesky().factor_bytes() +
                PolarCache::BytesFor(physics_.num_vertices(), physics_.num_elements())) /
               1e9;
  // (The budget is per process: a rank keeps the factors of the poses it owns.)
  // (One pose too: its solver then keeps its own factor, where a shared one refactorized
  // at every evaluation, 6x the factorizations of two poses' per-pose layout.)
  solver_per_pose_ = factor_gb_ * num_owned <= options.max_factor_cache_gb;
  // Otherwise the budget keeps single-precision copies of the first poses' factors.
  stored_factor_gb_ = first->stiffness_factorization()->cholesky().stored_factor_bytes() / 1e9;
  if (!solver_per_pose_ && num_poses_ > 1 && stored_factor_gb_ > 0.0) {
    num_stored_factors_ = static_cast<int>(std::min<double>(
        num_owned, std::floor(options.max_factor_cache_gb / stored_factor_gb_)));
    stored_factors_.resize(num_stored_factors_);
  }
  // A factor of another pose is a poor preconditioner: with shared solvers a pose's
  // solve starts by factorizing (StiffnessFactorization::RequestRefresh in StartPose)
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

bool EndToEndObjective::KeptSurfaceErrors(double* mean, double* max) const {
  if (kept_.parameters.size() == 0) return false;
  *mean = kept_.mean_surface_error;
  *max = kept_.max_surface_error;
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
  refit.energy_regularization = options_.energy_regularization;
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
  // In rounds: in round k every rank sends the state of its k-th pose (3 x vertices; none
  // when it owns fewer), so that no count or offset of one gather exceeds ranks x 3 x
  // vertices (a gather of all poses at once overflowed MPI's int counts from 3 x
  // vertices x poses >= 2^31). A pose without a state (never converged) is sent as NaN
  // and comes back empty; rank 0 puts them in place.
  const int nv = model_.mesh.num_vertices();
  const int block = 3 * nv;
  std::vector<std::vector<int>> owned_by(size_);
  size_t rounds = 0;
  for (int r = 0; r < size_; ++r) {
    owned_by[r] = OwnedIndices(num_poses_, r, size_);
    rounds = std::max(rounds, owned_by[r].size());
  }
  std::vector<Eigen::Matrix3Xd> gathered(rank_ == 0 ? num_poses_ : 0);
  std::vector<double> send(block);
  std::vector<double> received(rank_ == 0 ? static_cast<size_t>(block) * size_ : 0);
  std::vector<int> counts(size_);
  for (size_t k = 0; k < rounds; ++k) {
    for (int r = 0; r < size_; ++r) counts[r] = k < owned_by[r].size() ? block : 0;
    if (k < owned_.size()) {
      const Eigen::Matrix3Xd& x = (*states)[owned_[k]];
      if (x.cols() == nv) {
        std::copy(x.data(), x.data() + block, send.begin());
      } else {
        std::fill(send.begin(), send.end(), std::numeric_limits<double>::quiet_NaN());
      }
    }
    communicator_->GatherToRoot(send.data(), counts, received.data());
    if (rank_ != 0) continue;
    size_t offset = 0;
    for (int r = 0; r < size_; ++r) {
      if (k >= owned_by[r].size()) continue;
      const Eigen::Map<const Eigen::Matrix3Xd> x(received.data() + offset, 3, nv);
      offset += block;
      if (x.allFinite()) gathered[owned_by[r][k]] = x;
    }
  }
  if (rank_ == 0) *states = std::move(gathered);
}

}  // namespace aqs
