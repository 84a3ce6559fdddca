#include "equilibrium/quasistatic_solver.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <ceres/problem.h>
#include <ceres/solver.h>
#include <glog/logging.h>

#include "equilibrium/shape_target_cost_function.h"
#include "util/wall_timer.h"

namespace aqs {

std::string QuasistaticSolveReport::Summary() const {
  std::ostringstream out;
  out.precision(4);
  out << (converged ? "converged" : "NOT CONVERGED") << ": " << iterations << " iterations ("
      << successful_iterations << " accepted), energy " << initial_energy << " -> "
      << final_energy << ", max force " << initial_max_force << " -> " << final_max_force
      << " (tolerance " << force_tolerance << "), " << seconds << " s; " << termination;
  return out.str();
}

QuasistaticSolver::QuasistaticSolver(const ShapeTargetModel& model, const BoundaryConditions& bc,
                                     const QuasistaticSolverOptions& options)
    : model_(model),
      options_(options),
      fixed_vertices_(bc.vertices),
      fixed_mask_(FixedVertexMask(bc, model.num_vertices())),
      actuation_(6 * static_cast<size_t>(model.num_elements())),
      positions_(model.rest_positions().data(),
                 model.rest_positions().data() + 3 * static_cast<size_t>(model.num_vertices())) {
  actuation() = IdentityActuations(model.num_elements());
  std::string error;
  CHECK(ValidateBoundaryConditions(bc, model.num_vertices(), "boundary conditions", &error))
      << error;
  if (bc.positions.cols() == 0) {
    fixed_positions_.resize(3, fixed_vertices_.size());
    for (size_t i = 0; i < fixed_vertices_.size(); ++i) {
      fixed_positions_.col(i) = model.rest_positions().col(fixed_vertices_[i]);
    }
  } else {
    fixed_positions_ = bc.positions;
  }
  ApplyFixedPositions();

  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(problem_options);
  const Eigen::Matrix4Xi& tets = model.tets();
  for (int e = 0; e < model.num_elements(); ++e) {
    auto* cost = new ShapeTargetCostFunction(model.gradient_weights(e), model.rest_shape(e).volume,
                                             model.mu(e), actuation_.data() + 6 * static_cast<size_t>(e));
    problem_->AddResidualBlock(cost, nullptr, vertex(tets(0, e)), vertex(tets(1, e)),
                               vertex(tets(2, e)), vertex(tets(3, e)));
  }
  for (int v : fixed_vertices_) {
    double* block = vertex(v);
    if (problem_->HasParameterBlock(block)) problem_->SetParameterBlockConstant(block);
  }
}

QuasistaticSolver::~QuasistaticSolver() = default;

void QuasistaticSolver::ApplyFixedPositions() {
  for (size_t i = 0; i < fixed_vertices_.size(); ++i) {
    Eigen::Map<Eigen::Vector3d>(vertex(fixed_vertices_[i])) = fixed_positions_.col(i);
  }
}

void QuasistaticSolver::SetPositions(const Eigen::Matrix3Xd& positions) {
  CHECK_EQ(positions.cols(), model_.num_vertices());
  std::copy(positions.data(), positions.data() + positions.size(), positions_.data());
  ApplyFixedPositions();
}

void QuasistaticSolver::SetFixedPositions(const Eigen::Matrix3Xd& fixed_positions) {
  CHECK_EQ(fixed_positions.cols(), static_cast<Eigen::Index>(fixed_vertices_.size()));
  CHECK(fixed_positions.allFinite());
  fixed_positions_ = fixed_positions;
  ApplyFixedPositions();
}

double QuasistaticSolver::ForceTolerance() const {
  return options_.relative_force_tolerance * model_.force_scale();
}

double QuasistaticSolver::MaxFreeForce(double* energy) const {
  Eigen::Matrix3Xd gradient;
  const double e = model_.EnergyAndGradient(positions(), actuation(), &gradient,
                                            options_.num_threads);
  if (energy != nullptr) *energy = e;
  double max_force = 0.0;
  for (int v = 0; v < model_.num_vertices(); ++v) {
    if (!fixed_mask_[v]) max_force = std::max(max_force, gradient.col(v).norm());
  }
  return max_force;
}

QuasistaticSolveReport QuasistaticSolver::Solve() {
  WallTimer timer;
  QuasistaticSolveReport report;
  report.force_tolerance = ForceTolerance();
  ApplyFixedPositions();
  report.initial_max_force = MaxFreeForce(&report.initial_energy);
  report.final_energy = report.initial_energy;
  report.final_max_force = report.initial_max_force;
  if (!std::isfinite(report.initial_energy)) {
    report.termination = "the starting state has a non-finite energy";
    report.seconds = timer.Seconds();
    return report;
  }
  if (report.initial_max_force <= report.force_tolerance) {
    report.converged = true;
    report.termination = "the starting state is already in equilibrium";
    report.seconds = timer.Seconds();
    return report;
  }

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver_options.dynamic_sparsity = options_.dynamic_sparsity;
  solver_options.num_threads = options_.num_threads;
  solver_options.max_num_iterations = options_.max_iterations;
  solver_options.minimizer_progress_to_stdout = options_.log_progress;
  solver_options.logging_type = options_.log_progress ? ceres::PER_MINIMIZER_ITERATION
                                                      : ceres::SILENT;
  // Ceres tests the max-norm of dE/dx; a per-vertex norm <= tol needs components <= tol/sqrt 3.
  solver_options.gradient_tolerance = report.force_tolerance / std::sqrt(3.0);
  solver_options.function_tolerance = options_.function_tolerance;
  solver_options.parameter_tolerance = options_.parameter_tolerance;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, problem_.get(), &summary);

  report.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  report.successful_iterations = summary.num_successful_steps;
  report.termination = summary.message;
  report.final_max_force = MaxFreeForce(&report.final_energy);
  report.converged = report.final_max_force <= report.force_tolerance &&
                     summary.termination_type != ceres::FAILURE;
  report.seconds = timer.Seconds();
  return report;
}

}  // namespace aqs
