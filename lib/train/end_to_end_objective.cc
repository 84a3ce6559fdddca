#include "train/end_to_end_objective.h"

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
  workers_.resize(std::max(1, std::min(options.num_threads, num_poses_)));
  for (Worker& w : workers_) {
    w.solver = std::make_unique<QuasistaticSolver>(physics_, bc, solver_options);
    w.differentiator = std::make_unique<EquilibriumDifferentiator>(
        w.solver->stiffness_factorization(), EquilibriumDifferentiatorOptions{1});
  }
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
  return StatesAt(parameters, &states_);
}

bool EndToEndObjective::Evaluate(const double* parameters, double* cost, double* gradient) const {
  if (deadline_ > 0.0 && timer_.Seconds() > deadline_) {
    last_failure_ = "the time limit has passed";
    return false;
  }
  const Eigen::Map<const Eigen::MatrixXd> latents(parameters + num_params_, latent_dim_,
                                                  num_poses_);
  std::vector<ActuationMatrix> a;
  DecoderWorkspace workspace;
  model_.decoder->DecodeBatch(parameters, latents, &a, &workspace);
  const int n = model_.num_surface_vertices();
  const double scale = 1.0 / (static_cast<double>(num_poses_) * n);
  std::vector<ActuationMatrix> dl_da(num_poses_);
  ParallelFor(static_cast<int>(workers_.size()), 0, num_poses_, [&](int t, int p) {
    failures_[p].clear();
    Worker& w = workers_[t];
    w.solver->SetFixedPositions(fixed_positions_[p]);
    w.solver->actuation() = a[p];
    w.solver->SetPositions(states_[p]);
    QuasistaticSolveReport report = w.solver->Solve();
    if (!report.converged && !converged_once_[p]) {  // retry from rest
      w.solver->SetPositions(model_.mesh.vertices);
      report = w.solver->Solve();
    }
    if (!report.converged) {
      failures_[p] = "pose '" + model_.poses[p].name + "': " + report.Summary();
      return;
    }
    const Eigen::Matrix3Xd x = w.solver->positions();
    states_[p] = x;
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
    std::string error;
    if (!w.differentiator->Prepare(x, a[p], &error)) {
      failures_[p] = "pose '" + model_.poses[p].name + "': " + error;
      return;
    }
    dl_da[p] = w.differentiator->LossGradient(dl_dx);
  }, 1);
  for (const std::string& failure : failures_) {
    if (!failure.empty()) {
      last_failure_ = failure;
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
    Eigen::Map<Eigen::VectorXd>(gradient, NumParameters()).setZero();
    Eigen::MatrixXd latent_gradient;
    model_.decoder->Backward(parameters, workspace, dl_da, gradient, &latent_gradient);
    Eigen::Map<Eigen::MatrixXd>(gradient + num_params_, latent_dim_, num_poses_) =
        latent_gradient + (2.0 * options_.latent_regularization / num_poses_) * latents;
  }
  return std::isfinite(*cost);
}

}  // namespace aqs
