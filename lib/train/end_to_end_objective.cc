#include "train/end_to_end_objective.h"

#include "diff/actuation_force_products.h"
#include "geometry/embedding.h"
#include "util/parallel_for.h"

namespace aqs {

EndToEndObjective::EndToEndObjective(const TrainOptions& options, const ActiveModel& model)
    : options_(options),
      model_(model),
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
  QuasistaticSolverOptions solver_options = options.solver;
  solver_options.num_threads = 1;
  const BoundaryConditions bc = PoseBoundaryConditions(model_, 0);
  // One solver per pose if all their factors fit the budget: the first solver's
  // symbolic analysis gives the factor's size.
  auto first = std::make_unique<QuasistaticSolver>(physics_, bc, solver_options);
  first->stiffness_factorization()->Analyze();
  const double factor_gb = 8.0 * first->stiffness_factorization()->cholesky().factor_nonzeros() / 1e9;
  solver_per_pose_ = num_poses_ > 1 && factor_gb * num_poses_ <= options.max_factor_cache_gb;
  // A factor of another pose is a poor preconditioner: with shared solvers the Newton
  // steps factorize (the adjoint still reuses the factor of its own pose's solve).
  if (!solver_per_pose_) solver_options.factor_reuse.max_iterations = 0;
  first->set_options(solver_options);
  EquilibriumDifferentiatorOptions differentiator_options;
  differentiator_options.num_threads = 1;
  differentiator_options.reuse = {20, 1e-10, 6, 1e-2, 1, 8};
  workers_.resize(solver_per_pose_ ? num_poses_ : std::max(1, std::min(options.num_threads, num_poses_)));
  for (size_t i = 0; i < workers_.size(); ++i) {
    Worker& w = workers_[i];
    w.solver = i == 0 ? std::move(first)
                      : std::make_unique<QuasistaticSolver>(physics_, bc, solver_options);
    w.differentiator = std::make_unique<EquilibriumDifferentiator>(
        w.solver->stiffness_factorization(), differentiator_options);
  }
  state_actuations_.resize(num_poses_);
  pose_loss_.resize(num_poses_);
  pose_mean_.resize(num_poses_);
  pose_max_.resize(num_poses_);
  failures_.resize(num_poses_);
  converged_once_.assign(num_poses_, 0);
}

EndToEndObjective::~EndToEndObjective() = default;

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

uint64_t EndToEndObjective::Key(const double* parameters) const {
  // FNV-1a over the bytes of the parameter vector.
  const auto* bytes = reinterpret_cast<const unsigned char*>(parameters);
  const size_t n = sizeof(double) * static_cast<size_t>(NumParameters());
  uint64_t hash = 1469598103934665603ull;
  for (size_t i = 0; i < n; ++i) hash = (hash ^ bytes[i]) * 1099511628211ull;
  return hash;
}

bool EndToEndObjective::StatesAt(const double* parameters,
                                 std::vector<Eigen::Matrix3Xd>* states) const {
  const uint64_t key = Key(parameters);
  for (auto it = remembered_.rbegin(); it != remembered_.rend(); ++it) {
    if (it->key == key) {
      *states = it->states;
      return true;
    }
  }
  return false;
}

bool EndToEndObjective::UseStatesOf(const double* parameters) {
  // The states' actuations are not remembered: no prediction from them.
  for (ActuationMatrix& a : state_actuations_) a.resize(6, 0);
  return StatesAt(parameters, &states_);
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

bool EndToEndObjective::Evaluate(const double* parameters, double* cost, double* gradient) const {
  if (deadline_ > 0.0 && timer_.Seconds() > deadline_) {
    last_failure_ = "the time limit has passed";
    return false;
  }
  WallTimer evaluation_timer;
  const Eigen::Map<const Eigen::MatrixXd> latents(parameters + num_params_, latent_dim_,
                                                  num_poses_);
  std::vector<ActuationMatrix> a;
  DecoderWorkspace workspace;
  model_.decoder->DecodeBatch(parameters, latents, &a, &workspace);
  double decoder_seconds = evaluation_timer.Seconds();
  const int n = model_.num_surface_vertices();
  const double scale = 1.0 / (static_cast<double>(num_poses_) * n);
  std::vector<ActuationMatrix> dl_da(num_poses_);
  std::vector<Counters> pose_counters(num_poses_);
  const int threads = std::max(1, std::min(options_.num_threads, num_poses_));
  ParallelFor(threads, 0, num_poses_, [&](int t, int p) {
    failures_[p].clear();
    Worker& w = workers_[solver_per_pose_ ? p : t];
    Counters& counters = pose_counters[p];
    const int cg_start = w.solver->stiffness_factorization()->counters().cg_iterations;
    WallTimer solve_timer;
    w.solver->SetFixedPositions(fixed_positions_[p]);
    w.solver->actuation() = a[p];
    w.solver->SetPositions(states_[p]);
    if (solver_per_pose_) PredictState(p, &w);
    QuasistaticSolveReport report = w.solver->Solve();
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
    const Eigen::Matrix3Xd x = w.solver->positions();
    states_[p] = x;
    if (solver_per_pose_) state_actuations_[p] = a[p];
    converged_once_[p] = 1;
    const Eigen::Matrix3Xd diff =
        EmbeddedPositions(model_.embedding, model_.mesh.tets, x) - model_.poses[p].surface;
    pose_loss_[p] = diff.squaredNorm() * scale;
    const Eigen::VectorXd distance = diff.colwise().norm();
    pose_mean_[p] = distance.mean();
    pose_max_[p] = distance.maxCoeff();
    if (gradient == nullptr) return;
    // dL/dx: the embedding's transpose applied to dL/dp_i = 2 scale diff_i.
    Eigen::Matrix3Xd dl_dx = Eigen::Matrix3Xd::Zero(3, x.cols());
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < 4; ++k) {
        dl_dx.col(model_.mesh.tets(k, model_.embedding.element[i])) +=
            2.0 * scale * model_.embedding.weights(k, i) * diff.col(i);
      }
    }
    WallTimer adjoint_timer;
    StiffnessFactorization& factorization = *w.solver->stiffness_factorization();
    const FactorizationCounters before = factorization.counters();
    std::string error;
    if (!w.differentiator->Prepare(x, a[p], &error) ||
        !w.differentiator->LossGradient(dl_dx, &dl_da[p], &error)) {
      failures_[p] = "pose '" + model_.poses[p].name + "': " + error;
      return;
    }
    const FactorizationCounters& after = factorization.counters();
    counters.adjoint_factorizations = after.factorizations - before.factorizations;
    counters.factorizations += counters.adjoint_factorizations;
    counters.reused_solves += after.reused_solves - before.reused_solves;
    counters.adjoint_seconds = adjoint_timer.Seconds();
    counters.cg_iterations = after.cg_iterations - cg_start;
  }, 1);
  Counters total;
  for (const Counters& c : pose_counters) total.Add(c);
  total.evaluations = 1;
  total.decoder_seconds = decoder_seconds;
  for (const std::string& failure : failures_) {
    if (!failure.empty()) {
      last_failure_ = failure;
      total.seconds = evaluation_timer.Seconds();
      last_counters_ = total;
      total_counters_.Add(total);  // a failed evaluation costs too
      return false;
    }
  }
  if (static_cast<int>(remembered_.size()) == kRememberedEvaluations) {
    remembered_.erase(remembered_.begin());
  }
  remembered_.push_back({Key(parameters), states_});
  double data = 0;
  for (double l : pose_loss_) data += l;
  *cost = data + options_.latent_regularization * latents.squaredNorm() / num_poses_;
  if (gradient != nullptr) {
    WallTimer backward_timer;
    Eigen::Map<Eigen::VectorXd>(gradient, NumParameters()).setZero();
    Eigen::MatrixXd latent_gradient;
    model_.decoder->Backward(parameters, workspace, dl_da, gradient, &latent_gradient);
    Eigen::Map<Eigen::MatrixXd>(gradient + num_params_, latent_dim_, num_poses_) =
        latent_gradient + (2.0 * options_.latent_regularization / num_poses_) * latents;
    decoder_seconds += backward_timer.Seconds();
  }
  total.decoder_seconds = decoder_seconds;
  total.seconds = evaluation_timer.Seconds();
  last_counters_ = total;
  total_counters_.Add(total);
  return std::isfinite(*cost);
}

}  // namespace aqs
