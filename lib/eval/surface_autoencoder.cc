#include "eval/surface_autoencoder.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <string>

#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>
#include <ceres/iteration_callback.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <glog/logging.h>

#include "fit/fit_target.h"
#include "fit/gaussian_prior_cost.h"
#include "fit/latent_fit.h"
#include "fit/latent_prior.h"
#include "train/latent_init.h"
#include "train/lbfgs_restarts.h"
#include "train/progress.h"
#include "train/solver_checkpoint.h"
#include "util/fault_injection.h"
#include "util/fnv_hash.h"
#include "util/number_format.h"
#include "util/wall_timer.h"
#include "util/option_checks.h"
#include "util/text_split.h"

namespace aqs {
namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

constexpr int kLbfgsRank = 10;
constexpr int kFitMaxIterations = 100;

// Residuals sqrt(1/K) (neutral_v + s m_v(z) - y) over the block z, where m is an MLP
// whose outputs are only the 3K rows of the listed vertices (the full decoder's hidden
// layers and the matching rows of its output layer).
class SurfaceFitCost final : public ceres::CostFunction {
 public:
  SurfaceFitCost(const Mlp& mlp, const Eigen::VectorXd& parameters, double output_scale,
                 const Eigen::Matrix3Xd& neutral, const std::vector<int>& vertices,
                 const Eigen::Matrix3Xd& positions)
      : mlp_(MlpSpec{mlp.input_dim(), mlp.spec().hidden_dims,
                     3 * static_cast<int>(vertices.size()), mlp.spec().activation,
                     mlp.spec().zero_at_origin, mlp.spec().linear_skip}),
        parameters_(mlp_.num_parameters()),
        output_scale_(output_scale),
        residual_scale_(std::sqrt(1.0 / static_cast<double>(vertices.size()))),
        offset_(3 * vertices.size()) {
    const int k = static_cast<int>(vertices.size());
    const int last = mlp.num_layers() - 1;
    const int width = mlp.widths()[last];
    const int n = mlp.output_dim();
    // The hidden layers come first in both layouts and are identical.
    std::copy(parameters.data(), parameters.data() + mlp.weight_offset(last), parameters_.data());
    const Eigen::Map<const Eigen::MatrixXd> w(parameters.data() + mlp.weight_offset(last), n, width);
    const Eigen::Map<const Eigen::VectorXd> b(parameters.data() + mlp.bias_offset(last), n);
    Eigen::Map<Eigen::MatrixXd> w_rows(parameters_.data() + mlp_.weight_offset(last), 3 * k, width);
    Eigen::Map<Eigen::VectorXd> b_rows(parameters_.data() + mlp_.bias_offset(last), 3 * k);
    // The skip weights' rows likewise (empty maps without a skip).
    const int skip_cols = mlp.spec().linear_skip ? mlp.input_dim() : 0;
    const Eigen::Map<const Eigen::MatrixXd> skip(parameters.data() + mlp.skip_offset(), n,
                                                 skip_cols);
    Eigen::Map<Eigen::MatrixXd> skip_rows(parameters_.data() + mlp_.skip_offset(), 3 * k,
                                          skip_cols);
    for (int i = 0; i < k; ++i) {
      const int v = vertices[i];
      w_rows.middleRows(3 * i, 3) = w.middleRows(3 * static_cast<Eigen::Index>(v), 3);
      b_rows.segment<3>(3 * i) = b.segment<3>(3 * static_cast<Eigen::Index>(v));
      skip_rows.middleRows(3 * i, 3) = skip.middleRows(3 * static_cast<Eigen::Index>(v), 3);
      // neutral_v - y: the residual without the network's part.
      offset_.segment<3>(3 * i) = neutral.col(v) - positions.col(i);
    }
    set_num_residuals(3 * k);
    mutable_parameter_block_sizes()->push_back(mlp.input_dim());
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int d = mlp_.input_dim();
    const Eigen::Map<const Eigen::VectorXd> z(parameters[0], d);
    Eigen::Map<Eigen::VectorXd> r(residuals, num_residuals());
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::MatrixXd jacobian;
      Eigen::VectorXd output;
      mlp_.InputJacobian(parameters_.data(), z, &jacobian, &output);
      Eigen::Map<RowMajorMatrix>(jacobians[0], num_residuals(), d) =
          (residual_scale_ * output_scale_) * jacobian;
      r = residual_scale_ * (offset_ + output_scale_ * output);
    } else {
      MlpWorkspace workspace;
      Eigen::MatrixXd output;
      mlp_.Forward(parameters_.data(), z, &output, &workspace);
      r = residual_scale_ * (offset_ + output_scale_ * output.col(0));
    }
    return r.allFinite();
  }

 private:
  const Mlp mlp_;
  Eigen::VectorXd parameters_;
  const double output_scale_;
  const double residual_scale_;
  Eigen::VectorXd offset_;  // 3K: neutral_v - y, vertex after vertex
};

}  // namespace

SurfaceAutoencoderObjective::SurfaceAutoencoderObjective(const Mlp& mlp,
                                                         const Eigen::MatrixXd& displacements,
                                                         double output_scale,
                                                         double latent_regularization)
    : mlp_(mlp),
      displacements_(displacements),
      output_scale_(output_scale),
      latent_regularization_(latent_regularization) {
  CHECK_EQ(displacements.rows(), mlp.output_dim());
  CHECK_EQ(displacements.rows() % 3, 0);
  CHECK_GT(displacements.cols(), 0);
}

int SurfaceAutoencoderObjective::NumParameters() const {
  return mlp_.num_parameters() + mlp_.input_dim() * num_surfaces();
}

double SurfaceAutoencoderObjective::Loss(const double* parameters, double* gradient,
                                         double* mean_squared_distance,
                                         double* max_distance) const {
  const int np = mlp_.num_parameters();
  const int d = mlp_.input_dim();
  const int p = num_surfaces();
  const double scale = 1.0 / (static_cast<double>(p) * (displacements_.rows() / 3));
  const Eigen::Map<const Eigen::MatrixXd> latents(parameters + np, d, p);
  mlp_.Forward(parameters, latents, &outputs_, &workspace_);
  // outputs_ becomes the residual s m(z_p) - D_p, column by column.
  outputs_ *= output_scale_;
  outputs_ -= displacements_;
  const double data = scale * outputs_.squaredNorm();
  if (mean_squared_distance != nullptr) *mean_squared_distance = data;
  if (max_distance != nullptr) {
    *max_distance = std::sqrt(Eigen::Map<const Eigen::Matrix3Xd>(outputs_.data(), 3, outputs_.size() / 3)
                                  .colwise()
                                  .squaredNorm()
                                  .maxCoeff());
  }
  const double regularization = latent_regularization_ * latents.squaredNorm() / p;
  if (gradient != nullptr) {
    // dL/dm = (2 s / (P N)) (s m - D), in place.
    outputs_ *= 2.0 * output_scale_ * scale;
    Eigen::Map<Eigen::VectorXd>(gradient, np).setZero();
    Eigen::MatrixXd latent_gradient;
    mlp_.Backward(parameters, workspace_, outputs_, gradient, &latent_gradient);
    Eigen::Map<Eigen::MatrixXd>(gradient + np, d, p) =
        latent_gradient + (2.0 * latent_regularization_ / p) * latents;
  }
  return data + regularization;
}

bool SurfaceAutoencoderObjective::Evaluate(const double* parameters, double* cost,
                                           double* gradient) const {
  // Tests make evaluations fail here, as a non-finite loss does (util/fault_injection.h).
  if (FailurePoint("autoencoder:evaluate")) return false;
  *cost = Loss(parameters, gradient);
  return std::isfinite(*cost);
}

bool SurfaceAutoencoderOptions::Validate(std::string* error) const {
  bool widths_ok = true;
  for (int width : hidden_dims) widths_ok = widths_ok && width >= 1;
  return OptionChecks()
      .IntAtLeast("latent_dim", latent_dim, 1)
      .Require(widths_ok, "hidden_dims must be positive widths")
      .Positive("output_scale", output_scale)
      .InRange("latent_regularization", latent_regularization, 0.0, kMaxRegularization)
      .IntAtLeast("max_iterations", max_iterations, 0)
      .IntAtLeast("max_restarts", max_restarts, 0)
      .Require(function_tolerance >= 0.0 && function_tolerance < 1.0,
               "function_tolerance must be in [0, 1) (is " + OptionValue(function_tolerance) +
                   ")")
      .IntAtLeast("log_every", log_every, 0)
      .NonNegative("checkpoint_seconds", checkpoint_seconds)
      .Done(error);
}

SurfaceAutoencoder::SurfaceAutoencoder() = default;
SurfaceAutoencoder::~SurfaceAutoencoder() = default;
SurfaceAutoencoder::SurfaceAutoencoder(SurfaceAutoencoder&&) noexcept = default;
SurfaceAutoencoder& SurfaceAutoencoder::operator=(SurfaceAutoencoder&&) noexcept = default;

namespace {

// The network's parameters (weights and biases of every layer, and the linear skip's)
// for `outputs` outputs, as a double (it may exceed an int).
double NetworkParameters(const SurfaceAutoencoderOptions& options, double outputs) {
  double parameters = 0.0, fan_in = options.latent_dim;
  for (int width : options.hidden_dims) {
    parameters += width * (fan_in + 1.0);
    fan_in = width;
  }
  parameters += outputs * (fan_in + 1.0);
  if (options.linear_skip) parameters += outputs * options.latent_dim;
  return parameters;
}

}  // namespace

double SurfaceAutoencoderMemoryBytes(const SurfaceAutoencoderOptions& options,
                                     int num_vertices, int num_surfaces) {
  const double outputs = 3.0 * num_vertices;
  const double parameters = NetworkParameters(options, outputs) +
                            static_cast<double>(options.latent_dim) * num_surfaces;
  constexpr double kArrays = 4.0 * kLbfgsRank;  // iterate, gradient, samples, history
  return 8.0 * (kArrays * parameters + 4.0 * outputs * num_surfaces);
}

CheckpointKey AutoencoderCheckpointKey(const SurfaceAutoencoderOptions& options,
                                       const Eigen::Matrix3Xd& neutral,
                                       const std::vector<Eigen::Matrix3Xd>& surfaces) {
  uint64_t hash = Fnv1a(neutral.data(), sizeof(double) * neutral.size(), kFnvOffsetBasis);
  for (const Eigen::Matrix3Xd& surface : surfaces) {
    const Eigen::Index size = surface.size();
    hash = Fnv1a(&size, sizeof(size), hash);
    hash = Fnv1a(surface.data(), sizeof(double) * size, hash);
  }
  std::ostringstream text;
  text << "latent_dim=" << options.latent_dim << " hidden=" << JoinInts(options.hidden_dims, "none")
       << " activation=" << ActivationName(options.activation)
       << " output_scale=" << FormatDouble(options.output_scale)
       << " anchored=" << options.anchored << " linear_skip=" << options.linear_skip
       << " latent_regularization=" << FormatDouble(options.latent_regularization)
       << " lbfgs_scaling=" << options.lbfgs_scaling << " seed=" << options.seed;
  char surfaces_hash[20];
  std::snprintf(surfaces_hash, sizeof(surfaces_hash), "%016llx",
                static_cast<unsigned long long>(hash));
  return {{"surfaces", surfaces_hash}, {"options", text.str()}};
}

bool SurfaceAutoencoder::Train(const Eigen::Matrix3Xd& neutral,
                               const std::vector<Eigen::Matrix3Xd>& surfaces,
                               const SurfaceAutoencoderOptions& options, std::ostream& log,
                               std::string* error) {
  WallTimer timer;
  if (!options.Validate(error)) {
    *error = "surface autoencoder options: " + *error;
    return false;
  }
  const int p = static_cast<int>(surfaces.size());
  const Eigen::Index n = neutral.cols();
  if (p == 0) {
    *error = "no training surfaces";
    return false;
  }
  if (n == 0) {
    *error = "the neutral surface has no vertices";
    return false;
  }
  if (!neutral.allFinite()) {
    *error = "the neutral surface has non-finite coordinates";
    return false;
  }
  if (3 * n > std::numeric_limits<int>::max()) {
    *error = "too many vertices (" + std::to_string(n) + ")";
    return false;
  }
  Eigen::MatrixXd displacements(3 * n, p);
  for (int i = 0; i < p; ++i) {
    if (surfaces[i].cols() != n) {
      *error = "training surface " + std::to_string(i) + " has " +
               std::to_string(surfaces[i].cols()) + " vertices; the neutral has " +
               std::to_string(n);
      return false;
    }
    if (!surfaces[i].allFinite()) {
      *error = "training surface " + std::to_string(i) + " has non-finite coordinates";
      return false;
    }
    Eigen::Map<Eigen::Matrix3Xd>(displacements.col(i).data(), 3, n) = surfaces[i] - neutral;
  }

  const int d = options.latent_dim;
  const double network_parameters = NetworkParameters(options, 3.0 * n);
  if (network_parameters + static_cast<double>(d) * p > std::numeric_limits<int>::max()) {
    *error = "the auto-encoder would have " +
             std::to_string(static_cast<long long>(network_parameters)) +
             " network parameters, more than " + std::to_string(std::numeric_limits<int>::max()) +
             " (narrower hidden_dims)";
    return false;
  }
  auto mlp = std::make_unique<Mlp>(
      MlpSpec{d, options.hidden_dims, static_cast<int>(3 * n), options.activation,
              options.anchored, options.linear_skip});
  const int np = mlp->num_parameters();
  Eigen::VectorXd x(static_cast<Eigen::Index>(np) + static_cast<Eigen::Index>(d) * p);
  mlp->InitializeParameters(options.seed, x.data());
  // The output bias starts at the mean displacement: the network then only learns the
  // variation around it. Anchored (surface(0) = neutral), the bias cancels and this does
  // nothing: the network starts near the neutral.
  Eigen::Map<Eigen::VectorXd>(x.data() + mlp->bias_offset(mlp->num_layers() - 1), 3 * n) =
      displacements.rowwise().mean() / options.output_scale;
  Eigen::Map<Eigen::MatrixXd>(x.data() + np, d, p) =
      WhitenedPcaScores(displacements, Eigen::VectorXd::Ones(3 * n), d);
  log << "surface autoencoder: " << p << " surfaces x " << n << " vertices, latent " << d << ", "
      << np << " network parameters\n";
  // The start of the training (deterministic: the same in every run of it), for its
  // initial loss also when a checkpoint is resumed.
  const Eigen::VectorXd fresh = x;
  // A checkpoint of an earlier run of this training.
  const bool checkpoints = !options.checkpoint_directory.empty();
  SolverCheckpoint start;
  if (checkpoints) {
    start.key = AutoencoderCheckpointKey(options, neutral, surfaces);
    SolverCheckpoint found;
    std::string why_not;
    if (ReadSolverCheckpoint(options.checkpoint_directory, start.key,
                             static_cast<int>(x.size()), &found, &why_not)) {
      start = std::move(found);
      x = start.parameters;
      log << "surface autoencoder: resuming after iteration " << start.iterations << " (loss "
          << start.loss << ") from the checkpoint in " << options.checkpoint_directory << "\n";
    } else if (!why_not.empty()) {
      log << "surface autoencoder: not resuming the checkpoint in "
          << options.checkpoint_directory << ": " << why_not << "; starting anew\n";
    }
  }

  auto* objective = new SurfaceAutoencoderObjective(*mlp, displacements, options.output_scale,
                                                    options.latent_regularization);
  ceres::GradientProblem problem(objective);  // takes ownership
  SurfaceAutoencoderReport report;
  report.initial_loss = objective->Loss(fresh.data(), nullptr);
  if (start.iterations > 0) {
    report.resumed_loss = objective->Loss(x.data(), nullptr);
    if (!SameLoss(report.resumed_loss, start.loss)) {
      // Its numbers were read as finite, but they are not the point it recorded: damaged.
      *error = "the checkpoint in " + options.checkpoint_directory + " resumed gives a loss of " +
               FormatDouble(report.resumed_loss) + " where it recorded " +
               FormatDouble(start.loss) + ": it is damaged; remove it to train anew";
      return false;
    }
  }
  ceres::GradientProblemSolver::Options solver_options;
  solver_options.line_search_direction_type = ceres::LBFGS;
  solver_options.max_lbfgs_rank = kLbfgsRank;
  solver_options.use_approximate_eigenvalue_bfgs_scaling = options.lbfgs_scaling;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = 1e-12;
  solver_options.parameter_tolerance = 1e-14;
  solver_options.logging_type = ceres::SILENT;
  // Restarts continue the iteration numbers of the progress lines and checkpoints.
  LbfgsRestartOptions restart_options;
  restart_options.max_iterations = options.max_iterations;
  restart_options.max_restarts = options.max_restarts;
  ProgressLogger progress("surface autoencoder", options.log_every, options.max_iterations,
                          log, start.iterations);
  restart_options.callbacks.push_back(&progress);
  // The checkpoints read the point reached from x (which RunLbfgsWithRestarts keeps at
  // the last accepted point).
  SolverCheckpointWriter writer(options.checkpoint_directory, start, options.checkpoint_seconds,
                                x.data(), static_cast<int>(x.size()));
  if (checkpoints) restart_options.callbacks.push_back(&writer);
  LbfgsRunReport run;
  run.iterations = start.iterations;
  if (start.iterations < options.max_iterations) {
    run = RunLbfgsWithRestarts(solver_options, problem, restart_options, start.iterations,
                               x.data(), log);
  } else {
    run.termination = start.iterations > 0 ? "the checkpoint had used the whole budget"
                                           : "no iterations in the budget";
  }
  if (!writer.error().empty()) {
    *error = "surface autoencoder training stopped: its checkpoint could not be written: " +
             writer.error();
    return false;
  }
  double mse = 0;
  report.final_loss = objective->Loss(x.data(), nullptr, &mse, &report.max_error);
  report.rms_error = std::sqrt(mse);
  report.iterations = run.iterations;
  report.iterations_before = start.iterations;
  report.restarts = run.restarts;
  if (checkpoints && report.iterations > start.iterations && std::isfinite(report.final_loss) &&
      !writer.Write(report.iterations, report.final_loss)) {
    *error = "surface autoencoder training's last checkpoint could not be written: " +
             writer.error();
    return false;
  }
  report.termination = run.termination;
  if (!std::isfinite(report.final_loss)) {
    *error = "surface autoencoder training diverged (" + run.termination + ")";
    return false;
  }
  // The prior of fits, learned from the trained latents as the physics model's is
  // (LearnFitPrior's latent part), centred on the neutral's training surface if any.
  const Eigen::Map<const Eigen::MatrixXd> latents(x.data() + np, d, p);
  int center = -1;
  for (int i = 0; i < p && center < 0; ++i) {
    if (IsNeutralSurface(surfaces[i], neutral)) center = i;
  }
  GaussianPrior latent_prior;
  std::string prior_error;
  if (!LearnLatentPrior(latents, center, FitPriorOptions(), &latent_prior, &prior_error)) {
    *error = "surface autoencoder: " + prior_error;
    return false;
  }
  report.seconds = timer.Seconds();
  log << "surface autoencoder: " << report.iterations << " iterations";
  if (report.restarts > 0) {
    log << " (" << report.restarts << " L-BFGS restart" << (report.restarts > 1 ? "s" : "")
        << ")";
  }
  log << ", loss " << report.initial_loss << " -> " << report.final_loss << ", rms error "
      << report.rms_error << ", max " << report.max_error << " ("
      << FormatDuration(report.seconds) << "; " << report.termination << ")\n";

  options_ = options;
  neutral_ = neutral;
  mlp_ = std::move(mlp);
  parameters_ = x.head(np);
  latents_ = latents;
  latent_prior_ = std::move(latent_prior);
  report_ = report;
  return true;
}

Eigen::Matrix3Xd SurfaceAutoencoder::Decode(const Eigen::VectorXd& z) const {
  CHECK(trained()) << "Decode() before Train()";
  CHECK_EQ(z.size(), latent_dim());
  MlpWorkspace workspace;
  Eigen::MatrixXd output;
  mlp_->Forward(parameters_.data(), z, &output, &workspace);
  return neutral_ +
         options_.output_scale * Eigen::Map<const Eigen::Matrix3Xd>(output.data(), 3, neutral_.cols());
}

std::unique_ptr<ceres::CostFunction> SurfaceAutoencoder::NewFitCostFunction(
    const std::vector<int>& vertices, const Eigen::Matrix3Xd& positions) const {
  CHECK(trained()) << "fitting before Train()";
  CHECK(!vertices.empty()) << "no vertices to fit";
  CHECK_EQ(positions.cols(), static_cast<Eigen::Index>(vertices.size()));
  for (int v : vertices) CHECK(v >= 0 && v < num_vertices()) << "vertex " << v << " out of range";
  return std::make_unique<SurfaceFitCost>(*mlp_, parameters_, options_.output_scale, neutral_,
                                          vertices, positions);
}

double SurfaceAutoencoder::FitPriorTerm(const Eigen::VectorXd& z, int num_points,
                                        const LatentFitOptions& fit) const {
  CHECK(trained()) << "fitting before Train()";
  CHECK_GE(num_points, 1);
  CHECK_EQ(z.size(), latent_dim());
  double cost = fit.latent_regularization * z.squaredNorm();
  if (fit.latent_prior > 0) {
    cost += fit.latent_prior / PriorPoints(static_cast<double>(num_points), fit.prior_points_cap) *
            latent_prior_.SquaredMahalanobis(z);
  }
  return cost;
}

bool SurfaceAutoencoder::FitLatent(const std::vector<int>& vertices,
                                   const Eigen::Matrix3Xd& positions,
                                   const Eigen::VectorXd& initial, const LatentFitOptions& fit,
                                   Eigen::VectorXd* z, double* rms) const {
  CHECK_EQ(initial.size(), latent_dim());
  std::unique_ptr<ceres::CostFunction> fit_cost = NewFitCostFunction(vertices, positions);
  Eigen::VectorXd latent = initial;
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  problem.AddResidualBlock(fit_cost.get(), nullptr, latent.data());
  // The priors of the physics model's fits (LatentFitter::AddPriorBlocks' latent part).
  LatentPrior regularization(latent_dim(), fit.latent_regularization);
  if (fit.latent_regularization > 0) {
    problem.AddResidualBlock(&regularization, nullptr, latent.data());
  }
  const double points = PriorPoints(static_cast<double>(vertices.size()), fit.prior_points_cap);
  GaussianPriorCost prior(latent_prior_.mean, latent_prior_.whitening,
                          std::max(0.0, fit.latent_prior) / points);
  if (fit.latent_prior > 0) problem.AddResidualBlock(&prior, nullptr, latent.data());
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = kFitMaxIterations;
  solver_options.function_tolerance = 1e-12;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable() || !latent.allFinite()) return false;
  // The data residuals at the solution: their squared norm is the mean squared distance.
  Eigen::VectorXd residuals(fit_cost->num_residuals());
  const double* block = latent.data();
  if (!fit_cost->Evaluate(&block, residuals.data(), nullptr)) return false;
  *z = latent;
  *rms = residuals.norm();
  return true;
}

}  // namespace aqs
