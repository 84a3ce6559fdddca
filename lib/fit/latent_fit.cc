#include "fit/latent_fit.h"

#include <sstream>

#include <ceres/cost_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <glog/logging.h>

#include "geometry/embedding.h"

namespace aqs {

FitTarget FullSurfaceTarget(const Eigen::Matrix3Xd& surface) {
  FitTarget target;
  target.vertices.resize(surface.cols());
  for (Eigen::Index i = 0; i < surface.cols(); ++i) target.vertices[i] = static_cast<int>(i);
  target.positions = surface;
  return target;
}

// Residuals sqrt(w_k / K) (p_{v_k}(x*(a(z))) - y_k) (3 K) over the block z.
class LatentFitter::FitCost final : public ceres::CostFunction {
 public:
  FitCost(LatentFitter* fitter, const FitTarget& target) : fitter_(fitter), target_(target) {
    const int k = static_cast<int>(target.vertices.size());
    set_num_residuals(3 * k);
    mutable_parameter_block_sizes()->push_back(fitter->model_.latent_dim());
    scale_.resize(k);
    for (int i = 0; i < k; ++i) {
      const double w = target.weights.size() > 0 ? target.weights[i] : 1.0;
      scale_[i] = std::sqrt(w / k);
    }
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const ActiveModel& model = fitter_->model_;
    const int d = model.latent_dim();
    const Eigen::Map<const Eigen::VectorXd> z(parameters[0], d);
    ActuationMatrix a;
    Eigen::MatrixXd da_dz;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      da_dz = model.decoder->ActuationJacobian(model.decoder_params.data(), z, &a);
    } else {
      DecoderWorkspace workspace;
      model.decoder->Decode(model.decoder_params.data(), z, &a, &workspace);
    }
    QuasistaticSolver& solver = *fitter_->solver_;
    const Eigen::Matrix3Xd start = solver.positions();
    solver.actuation() = a;
    QuasistaticSolveReport report = solver.Solve();
    if (!report.converged) {
      solver.SetPositions(model.mesh.vertices);
      report = solver.Solve();
      if (!report.converged) {
        solver.SetPositions(start);
        return false;  // Ceres treats the step as unsuccessful
      }
    }
    const Eigen::Matrix3Xd x = solver.positions();
    const int k = static_cast<int>(target_.vertices.size());
    for (int i = 0; i < k; ++i) {
      const int v = target_.vertices[i];
      Eigen::Vector3d p = model.embedding.offsets.col(v);
      for (int j = 0; j < 4; ++j) {
        p += model.embedding.weights(j, v) * x.col(model.mesh.tets(j, model.embedding.element[v]));
      }
      Eigen::Map<Eigen::Vector3d>(residuals + 3 * i) = scale_[i] * (p - target_.positions.col(i));
    }
    if (jacobians == nullptr || jacobians[0] == nullptr) return true;
    std::string error;
    if (!fitter_->differentiator_->Prepare(x, a, &error)) return false;
    const Eigen::MatrixXd dx_dz = fitter_->differentiator_->ActuationJacobianProduct(da_dz);
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac(
        jacobians[0], 3 * k, d);
    for (int i = 0; i < k; ++i) {
      const int v = target_.vertices[i];
      Eigen::Matrix<double, 3, Eigen::Dynamic> dp = Eigen::MatrixXd::Zero(3, d);
      for (int j = 0; j < 4; ++j) {
        const int vertex = model.mesh.tets(j, model.embedding.element[v]);
        dp += model.embedding.weights(j, v) * dx_dz.middleRows(3 * vertex, 3);
      }
      jac.middleRows(3 * i, 3) = scale_[i] * dp;
    }
    return true;
  }

 private:
  LatentFitter* fitter_;
  const FitTarget& target_;
  std::vector<double> scale_;
};

namespace {

// sqrt(lambda) z: the latent prior as residuals.
class LatentPrior final : public ceres::CostFunction {
 public:
  LatentPrior(int d, double lambda) : d_(d), scale_(std::sqrt(lambda)) {
    set_num_residuals(d);
    mutable_parameter_block_sizes()->push_back(d);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    for (int i = 0; i < d_; ++i) residuals[i] = scale_ * parameters[0][i];
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          jacobians[0], d_, d_) = scale_ * Eigen::MatrixXd::Identity(d_, d_);
    }
    return true;
  }

 private:
  int d_;
  double scale_;
};

}  // namespace

LatentFitter::LatentFitter(const ActiveModel& model, const LatentFitOptions& options)
    : model_(model), options_(options) {
  CHECK(model.decoder) << "latent fitting needs a trained model";
  physics_ = std::make_unique<ShapeTargetModel>(model.mesh, model.mu);
  QuasistaticSolverOptions solver_options = options.solver;
  solver_options.num_threads = options.num_threads;
  solver_ = std::make_unique<QuasistaticSolver>(
      *physics_, ModelBoundaryConditions(model, RestBoneTransforms(model)), solver_options);
  differentiator_ = std::make_unique<EquilibriumDifferentiator>(
      solver_->stiffness_factorization(), EquilibriumDifferentiatorOptions{options.num_threads});
}

LatentFitter::~LatentFitter() = default;

void LatentFitter::set_bone_transforms(const std::vector<RigidTransform>& transforms) {
  solver_->SetFixedPositions(ModelBoundaryConditions(model_, transforms).positions);
}

Eigen::VectorXd LatentFitter::MeanLatent() const { return model_.latents.rowwise().mean(); }

bool LatentFitter::Simulate(const Eigen::VectorXd& z, Eigen::Matrix3Xd* state,
                            Eigen::Matrix3Xd* surface, std::string* error) {
  ActuationMatrix a;
  DecoderWorkspace workspace;
  model_.decoder->Decode(model_.decoder_params.data(), z, &a, &workspace);
  solver_->actuation() = a;
  const QuasistaticSolveReport report = solver_->Solve();
  if (!report.converged) {
    *error = "the equilibrium was not reached: " + report.Summary();
    return false;
  }
  *state = solver_->positions();
  *surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, *state);
  return true;
}

bool LatentFitter::Fit(const FitTarget& target, const Eigen::VectorXd& initial,
                       LatentFitResult* result, std::string* error) {
  const int d = model_.latent_dim();
  CHECK_EQ(initial.size(), d);
  CHECK_EQ(target.positions.cols(), static_cast<Eigen::Index>(target.vertices.size()));
  for (int v : target.vertices) {
    CHECK(v >= 0 && v < model_.num_surface_vertices()) << "target vertex " << v;
  }
  Eigen::VectorXd z = initial;
  Eigen::Matrix3Xd state, surface;
  if (!Simulate(z, &state, &surface, error)) {
    *error = "at the initial latent: " + *error;
    return false;
  }
  ceres::Problem::Options problem_options;
  ceres::Problem problem(problem_options);
  problem.AddResidualBlock(new FitCost(this, target), nullptr, z.data());
  if (options_.latent_regularization > 0) {
    problem.AddResidualBlock(new LatentPrior(d, options_.latent_regularization), nullptr, z.data());
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options_.max_iterations;
  solver_options.function_tolerance = 1e-10;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-10;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!Simulate(z, &state, &surface, error)) return false;
  result->latent = z;
  result->state = state;
  result->surface = surface;
  const int k = static_cast<int>(target.vertices.size());
  Eigen::VectorXd distance(k);
  for (int i = 0; i < k; ++i) {
    distance[i] = (surface.col(target.vertices[i]) - target.positions.col(i)).norm();
  }
  result->rms_error = std::sqrt(distance.squaredNorm() / std::max(1, k));
  result->mean_error = distance.mean();
  result->max_error = distance.maxCoeff();
  result->iterations = static_cast<int>(summary.iterations.size()) - 1;
  result->converged = summary.termination_type == ceres::CONVERGENCE;
  result->message = summary.message;
  return true;
}

}  // namespace aqs
