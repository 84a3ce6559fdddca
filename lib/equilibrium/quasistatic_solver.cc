#include "equilibrium/quasistatic_solver.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <ceres/ordered_groups.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <glog/logging.h>

#include "equilibrium/newton_refinement.h"
#include "equilibrium/shape_target_cost_function.h"
#include "sparse/vertex_ordering.h"
#include "util/wall_timer.h"

namespace aqs {

std::string QuasistaticSolveReport::Summary() const {
  std::ostringstream out;
  out.precision(4);
  out << (converged ? "converged" : "NOT CONVERGED") << ": " << lm_iterations
      << " LM iterations (" << successful_iterations << " accepted) + " << newton_steps
      << " Newton steps, energy " << initial_energy << " -> "
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
  const double e = TotalEnergyAndGradient(model_, terms_, positions(), actuation(), &gradient,
                                          options_.num_threads);
  if (energy != nullptr) *energy = e;
  double max_force = 0.0;
  for (int v = 0; v < model_.num_vertices(); ++v) {
    if (!fixed_mask_[v]) max_force = std::max(max_force, gradient.col(v).norm());
  }
  return max_force;
}

StiffnessFactorization* QuasistaticSolver::stiffness_factorization() {
  if (!factorization_) {
    std::vector<std::vector<int>> couplings;
    for (const EnergyTerm* term : terms_) term->AppendVertexCouplings(&couplings);
    factorization_ = std::make_unique<StiffnessFactorization>(model_, fixed_mask_,
                                                              options_.num_threads, couplings);
    factorization_->set_energy_terms(terms_);
  }
  return factorization_.get();
}

void QuasistaticSolver::AddEnergyTerm(const EnergyTerm* term) {
  CHECK(term != nullptr);
  std::vector<double*> blocks(model_.num_vertices());
  for (int v = 0; v < model_.num_vertices(); ++v) blocks[v] = vertex(v);
  term->AddResidualBlocks(problem_.get(), blocks);
  // Blocks a term added for vertices in no element: keep fixed ones constant.
  for (int v : fixed_vertices_) {
    if (problem_->HasParameterBlock(vertex(v))) problem_->SetParameterBlockConstant(vertex(v));
  }
  terms_.push_back(term);
  std::vector<std::vector<int>> couplings;
  term->AppendVertexCouplings(&couplings);
  if (!couplings.empty()) {
    factorization_.reset();  // its pattern lacks the new couplings; rebuilt on next use
  } else if (factorization_) {
    factorization_->set_energy_terms(terms_);
  }
}

bool QuasistaticSolver::RunNewton(QuasistaticSolveReport* report) {
  NewtonRefinementOptions newton;
  newton.force_tolerance = report->force_tolerance;
  newton.max_steps = options_.max_newton_steps;
  Eigen::Matrix3Xd x = positions();
  const NewtonRefinementReport result =
      RefineEquilibrium(newton, actuation(), stiffness_factorization(), &x);
  SetPositions(x);
  report->newton_steps += result.steps;
  report->final_max_force = result.final_max_force;
  report->final_energy = result.final_energy;
  if (!report->termination.empty()) report->termination += "; ";
  report->termination += "Newton: " + result.message;
  return result.converged;
}

void QuasistaticSolver::RunCeres(double tolerance, QuasistaticSolveReport* report) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver_options.dynamic_sparsity = options_.ordering == NormalEquationsOrdering::kDynamic;
  solver_options.use_postordering = options_.use_postordering;
  if (options_.ordering == NormalEquationsOrdering::kVertexFillReducing) {
    if (vertex_order_.empty()) vertex_order_ = FillReducingVertexOrder(model_.tets(), fixed_mask_);
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    int group = 0;
    for (int v : vertex_order_) {
      double* block = vertex(v);
      if (problem_->HasParameterBlock(block)) ordering->AddElementToGroup(block, group++);
    }
    for (int v : fixed_vertices_) {
      double* block = vertex(v);
      if (problem_->HasParameterBlock(block)) ordering->AddElementToGroup(block, group);
    }
    solver_options.linear_solver_ordering = ordering;
  }
  solver_options.num_threads = options_.num_threads;
  solver_options.max_num_iterations = std::max(1, options_.max_iterations - report->iterations);
  solver_options.minimizer_progress_to_stdout = options_.log_progress;
  solver_options.logging_type = options_.log_progress ? ceres::PER_MINIMIZER_ITERATION
                                                      : ceres::SILENT;
  // Ceres tests the max-norm of dE/dx; a per-vertex norm <= tol needs components <= tol/sqrt 3.
  solver_options.gradient_tolerance = tolerance / std::sqrt(3.0);
  solver_options.function_tolerance = options_.function_tolerance;
  solver_options.parameter_tolerance = options_.parameter_tolerance;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, problem_.get(), &summary);

  const int iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  report->lm_iterations += iterations;
  report->iterations += iterations;
  // Ceres counts the initial evaluation as a successful step.
  report->successful_iterations += std::max(0, summary.num_successful_steps - 1);
  report->ceres_preprocessor_seconds += summary.preprocessor_time_in_seconds;
  report->ceres_minimizer_seconds += summary.minimizer_time_in_seconds;
  report->ceres_evaluation_seconds +=
      summary.residual_evaluation_time_in_seconds + summary.jacobian_evaluation_time_in_seconds;
  report->ceres_linear_solver_seconds += summary.linear_solver_time_in_seconds;
  if (!report->termination.empty()) report->termination += "; ";
  report->termination += "Ceres: " + summary.message;
  report->final_max_force = MaxFreeForce(&report->final_energy);
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
  // Newton needs a positive definite K (fixed vertices must remove rigid motions) and
  // every energy term's Hessian on the mesh's pattern.
  bool use_newton = options_.newton_relative_force > 0.0 && !fixed_vertices_.empty();
  for (const EnergyTerm* term : terms_) use_newton = use_newton && term->SupportsStiffness();
  const double newton_threshold =
      std::max(report.force_tolerance, options_.newton_relative_force * model_.force_scale());
  bool done = false;
  if (use_newton && report.initial_max_force <= newton_threshold) {
    done = RunNewton(&report);  // a warm start near the answer
  }
  if (!done) {
    RunCeres(use_newton ? newton_threshold : report.force_tolerance, &report);
    done = report.final_max_force <= report.force_tolerance;
    if (!done && use_newton && report.final_max_force <= newton_threshold) {
      done = RunNewton(&report);
      if (!done && report.iterations < options_.max_iterations) {
        RunCeres(report.force_tolerance, &report);  // Newton failed: Ceres to the end
      }
    }
  }
  report.iterations = report.lm_iterations + report.newton_steps;
  report.converged = report.final_max_force <= report.force_tolerance &&
                     std::isfinite(report.final_energy);
  report.seconds = timer.Seconds();
  return report;
}

}  // namespace aqs
