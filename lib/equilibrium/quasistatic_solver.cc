#include "equilibrium/quasistatic_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include <ceres/ordered_groups.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <glog/logging.h>

#include "equilibrium/newton_solver.h"
#include "equilibrium/preconditioned_lbfgs.h"
#include "equilibrium/shape_target_cost_function.h"
#include "sparse/vertex_ordering.h"
#include "util/number_format.h"
#include "util/wall_timer.h"

namespace aqs {

std::string QuasistaticSolverOptions::KeyText() const {
  const FactorReuseOptions& r = factor_reuse;
  std::ostringstream text;
  text << static_cast<int>(method) << " " << FormatDouble(relative_force_tolerance) << " "
       << max_iterations << " " << max_lbfgs_iterations << " " << lbfgs_reuses_factor << " "
       << lbfgs_reused_factor_stall_iterations << " " << negative_curvature_steps << " "
       << ensure_stable << " " << static_cast<int>(ordering) << " " << use_postordering << " "
       << FormatDouble(newton_relative_force) << " reuse " << r.max_iterations << " "
       << FormatDouble(r.relative_tolerance) << " " << r.probe_iterations << " "
       << FormatDouble(r.probe_tolerance) << " " << r.max_columns << " " << r.refresh_iterations
       << " " << FormatDouble(function_tolerance) << " " << FormatDouble(parameter_tolerance);
  if (newton_stall_steps != kDefaultNewtonStallSteps) text << " stall " << newton_stall_steps;
  return text.str();
}

bool QuasistaticSolverOptions::Validate(std::string* error) const {
  std::ostringstream out;
  if (!(relative_force_tolerance > 0.0) || !std::isfinite(relative_force_tolerance)) {
    out << "relative_force_tolerance must be finite and > 0 (is " << relative_force_tolerance
        << ")";
  } else if (max_iterations < 1) {
    out << "max_iterations must be >= 1 (is " << max_iterations << ")";
  } else if (max_lbfgs_iterations < 0) {
    out << "max_lbfgs_iterations must be >= 0 (is " << max_lbfgs_iterations << ")";
  } else if (lbfgs_reused_factor_stall_iterations < 0) {
    out << "lbfgs_reused_factor_stall_iterations must be >= 0 (is "
        << lbfgs_reused_factor_stall_iterations << ")";
  } else if (newton_stall_steps < 0) {
    out << "newton_stall_steps must be >= 0 (is " << newton_stall_steps << ")";
  } else if (num_threads < 1 || num_threads > 1024) {
    out << "num_threads must be in [1, 1024] (is " << num_threads << ")";
  } else if (!(newton_relative_force >= 0.0) || !std::isfinite(newton_relative_force)) {
    out << "newton_relative_force must be finite and >= 0 (is " << newton_relative_force << ")";
  } else if (std::string reuse_error; !factor_reuse.Validate(&reuse_error)) {
    out << "factor_reuse." << reuse_error;
  } else if (!(factor_reuse.relative_tolerance > 0.0) || factor_reuse.max_columns < 1) {
    out << "factor_reuse needs relative_tolerance > 0 and max_columns >= 1";
  } else if (!(function_tolerance >= 0.0) || !std::isfinite(function_tolerance)) {
    out << "function_tolerance must be finite and >= 0 (is " << function_tolerance << ")";
  } else if (!(parameter_tolerance >= 0.0) || !std::isfinite(parameter_tolerance)) {
    out << "parameter_tolerance must be finite and >= 0 (is " << parameter_tolerance << ")";
  }
  *error = out.str();
  return error->empty();
}

std::string QuasistaticSolveReport::Path() const {
  std::vector<std::string> parts;
  if (lm_iterations > 0) {
    parts.push_back("LM " + std::to_string(lm_iterations) + " iterations (" +
                    std::to_string(successful_iterations) + " accepted)");
  }
  if (lbfgs_iterations > 0) {
    parts.push_back("L-BFGS " + std::to_string(lbfgs_iterations) + " iterations" +
                    (lbfgs_stalled ? " (stalled)" : ""));
  }
  if (newton_hand_backs > 0) {
    parts.push_back(std::to_string(newton_hand_backs) + " hand-backs to L-BFGS");
  }
  if (newton_steps > 0) {
    std::string newton = "Newton " + std::to_string(projected_steps) + " projected + " +
                         std::to_string(exact_steps) + " exact steps";
    if (reused_steps > 0) newton += " (" + std::to_string(reused_steps) + " by CG on an earlier factor)";
    if (newton_stalled) newton += " (stalled)";
    parts.push_back(newton);
  }
  std::string path = parts.empty() ? std::string("no iterations") : parts[0];
  for (size_t i = 1; i < parts.size(); ++i) path += " + " + parts[i];
  path += ", " + std::to_string(factorizations) + " factorizations";
  if (shifted_factorizations > 0) path += " (" + std::to_string(shifted_factorizations) + " shifted)";
  if (unstable_escapes > 0) path += ", left " + std::to_string(unstable_escapes) + " unstable equilibria";
  if (stability_checked) path += stable ? ", stable" : ", UNSTABLE";
  return path;
}

std::string QuasistaticSolveReport::Summary() const {
  std::ostringstream out;
  out.precision(4);
  out << (converged ? "converged" : "NOT CONVERGED") << ": " << Path() << ", energy "
      << initial_energy << " -> " << final_energy << ", max force " << initial_max_force
      << " -> " << final_max_force << " (tolerance " << force_tolerance << "), " << seconds
      << " s; " << termination;
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
  // Options are the caller's to validate (the jobs do, naming the flags): invalid ones
  // here are a programmer error.
  CHECK(options.Validate(&error)) << "QuasistaticSolverOptions: " << error;
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
}

QuasistaticSolver::~QuasistaticSolver() = default;

ceres::Problem* QuasistaticSolver::problem() {
  if (problem_) return problem_.get();
  // One ShapeTargetCostFunction per element over its four vertex blocks, then the energy
  // terms' blocks; fixed vertices constant. Built on first use (Levenberg-Marquardt only).
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(problem_options);
  const Eigen::Matrix4Xi& tets = model_.tets();
  for (int e = 0; e < model_.num_elements(); ++e) {
    auto* cost = new ShapeTargetCostFunction(model_.gradient_weights(e), model_.rest_shape(e).volume,
                                             model_.mu(e), actuation_.data() + 6 * static_cast<size_t>(e));
    problem_->AddResidualBlock(cost, nullptr, vertex(tets(0, e)), vertex(tets(1, e)),
                               vertex(tets(2, e)), vertex(tets(3, e)));
  }
  std::vector<double*> blocks(model_.num_vertices());
  for (int v = 0; v < model_.num_vertices(); ++v) blocks[v] = vertex(v);
  for (const EnergyTerm* term : terms_) term->AddResidualBlocks(problem_.get(), blocks);
  for (int v : fixed_vertices_) {
    double* block = vertex(v);
    if (problem_->HasParameterBlock(block)) problem_->SetParameterBlockConstant(block);
  }
  return problem_.get();
}

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

void QuasistaticSolver::PerturbFreeVertices(double relative_size, unsigned seed) {
  const Eigen::Matrix3Xd& rest = model_.rest_positions();
  const Eigen::Matrix4Xi& tets = model_.tets();
  double edge_sum = 0.0;
  for (int e = 0; e < tets.cols(); ++e) {
    for (int i = 0; i < 4; ++i) {
      for (int j = i + 1; j < 4; ++j) edge_sum += (rest.col(tets(i, e)) - rest.col(tets(j, e))).norm();
    }
  }
  const double size = relative_size * edge_sum / std::max<Eigen::Index>(1, 6 * tets.cols());
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int v = 0; v < model_.num_vertices(); ++v) {
    if (fixed_mask_[v]) continue;
    for (int c = 0; c < 3; ++c) positions_[3 * v + c] += size * uniform(generator);
  }
}

void QuasistaticSolver::SetFixedPositions(const Eigen::Matrix3Xd& fixed_positions) {
  CHECK_EQ(fixed_positions.cols(), static_cast<Eigen::Index>(fixed_vertices_.size()));
  // Non-finite positions are data (a lost marker, a bone of NaN): Solve refuses them.
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
    if (fixed_mask_[v]) continue;
    const double force = gradient.col(v).norm();
    if (std::isnan(force) || force > max_force) max_force = force;  // a NaN force: NaN, kept
  }
  return max_force;
}

void ActuationView::CheckAssignedSize(Eigen::Index rows, Eigen::Index cols) const {
  CHECK(rows == 6 && cols == this->cols())
      << "the solver's actuation is 6 x " << this->cols()
      << " (one column per element); a matrix of " << rows << " x " << cols
      << " was assigned to it";
}

void QuasistaticSolver::set_options(const QuasistaticSolverOptions& options) {
  std::string error;
  CHECK(options.Validate(&error)) << "QuasistaticSolverOptions: " << error;
  options_ = options;
}

StiffnessFactorization* QuasistaticSolver::stiffness_factorization() {
  factorization_handed_out_ = true;
  return OwnFactorization();
}

StiffnessFactorization* QuasistaticSolver::OwnFactorization() {
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
  // The Ceres problem, if already built, gets the term's blocks too (fixed vertices'
  // blocks a term added for vertices in no element stay constant).
  if (problem_) {
    std::vector<double*> blocks(model_.num_vertices());
    for (int v = 0; v < model_.num_vertices(); ++v) blocks[v] = vertex(v);
    term->AddResidualBlocks(problem_.get(), blocks);
    for (int v : fixed_vertices_) {
      if (problem_->HasParameterBlock(vertex(v))) problem_->SetParameterBlockConstant(vertex(v));
    }
  }
  terms_.push_back(term);
  std::vector<std::vector<int>> couplings;
  term->AppendVertexCouplings(&couplings);
  if (!couplings.empty()) {
    CHECK(!factorization_handed_out_)
        << "AddEnergyTerm: a term with vertex couplings replaces the stiffness factorization, "
           "which stiffness_factorization() has handed out (to an EquilibriumDifferentiator?): "
           "add the energy terms first";
    factorization_.reset();  // its pattern lacks the new couplings; rebuilt on next use
    preconditioner_.reset();
  } else {
    if (factorization_) factorization_->set_energy_terms(terms_);
    if (preconditioner_) preconditioner_->set_energy_terms(terms_);
  }
  preconditioner_current_ = false;
}

bool QuasistaticSolver::RunNewton(double exact_threshold, QuasistaticSolveReport* report,
                                  int hand_back_after) {
  NewtonSolverOptions newton;
  newton.hand_back_after_projected_steps = hand_back_after;
  newton.force_tolerance = report->force_tolerance;
  newton.exact_force_threshold = exact_threshold;
  newton.max_factorizations = std::max(1, options_.max_iterations - report->iterations);
  // Steps by CG: the whole solve's budget, whatever L-BFGS used of it.
  newton.max_reused_steps = options_.max_iterations;
  newton.reuse = options_.factor_reuse;
  newton.negative_curvature_steps = options_.negative_curvature_steps;
  newton.stall_steps = options_.newton_stall_steps;
  Eigen::Matrix3Xd x = positions();
  const NewtonSolveReport result =
      MinimizeEnergyNewton(newton, actuation(), OwnFactorization(), &x);
  SetPositions(x);
  report->projected_steps += result.projected_steps;
  report->exact_steps += result.exact_steps;
  report->reused_steps += result.reused_steps;
  report->newton_steps += result.projected_steps + result.exact_steps;
  report->factorizations += result.factorizations;
  report->shifted_factorizations += result.shifted_factorizations;
  report->line_search_evaluations += result.energy_evaluations;
  report->iterations += result.factorizations;
  report->final_max_force = result.final_max_force;
  report->final_energy = result.final_energy;
  report->newton_stalled = report->newton_stalled || result.stalled;
  if (result.handed_back) ++report->newton_hand_backs;
  if (!report->termination.empty()) report->termination += "; ";
  report->termination += "Newton: " + result.message;
  return result.converged;
}

void QuasistaticSolver::RunLbfgs(double tolerance, QuasistaticSolveReport* report) {
  if (options_.lbfgs_reuses_factor) {
    StiffnessFactorization* own = OwnFactorization();
    if (own->factorized()) {
      // A factor marked for refreshing (an aged one) is a poor preconditioner, and Newton
      // factorizes anyway: its steps start at once (L-BFGS on it cost more in 240K
      // training: docs/scale.md).
      if (!own->refresh_requested()) {
        RunLbfgsWith(own, tolerance, options_.lbfgs_reused_factor_stall_iterations, report);
      }
      return;
    }
  }
  bool constant = true;
  for (const EnergyTerm* term : terms_) constant = constant && term->HasConstantHessian();
  if (!preconditioner_) {
    std::vector<std::vector<int>> couplings;
    for (const EnergyTerm* term : terms_) term->AppendVertexCouplings(&couplings);
    preconditioner_ = std::make_unique<StiffnessFactorization>(model_, fixed_mask_,
                                                               options_.num_threads, couplings);
    preconditioner_->set_energy_terms(terms_);
    preconditioner_current_ = false;
  }
  if (!preconditioner_current_ || !constant) {
    std::string error;
    preconditioner_->Assemble(positions(), actuation(), StiffnessKind::kRotationFixed);
    ++report->factorizations;
    ++report->iterations;
    // The rotation-fixed K is PSD: where it does not factorize it is singular (a piece
    // nothing holds), and a small shift makes it definite.
    bool factorized = preconditioner_->FactorizeAssembled(0.0, &error);
    if (!factorized) {
      std::string shifted_error;
      ++report->factorizations;
      factorized = preconditioner_->FactorizeAssembled(kSingularShift, &shifted_error);
    }
    if (!factorized) {
      if (!report->termination.empty()) report->termination += "; ";
      report->termination += "L-BFGS: no preconditioner: " + error;
      if (options_.lbfgs_reuses_factor) {  // as after the L-BFGS phase: not kept
        preconditioner_.reset();
        preconditioner_current_ = false;
      }
      return;  // Newton's projected steps take over
    }
    preconditioner_current_ = true;
  }
  RunLbfgsWith(preconditioner_.get(), tolerance, /*stall_iterations=*/0, report);
  if (options_.lbfgs_reuses_factor) {
    // Built for want of an earlier factor (a first solve): released, so that a solver
    // holds one factor between solves.
    preconditioner_.reset();
    preconditioner_current_ = false;
  }
}

void QuasistaticSolver::RunLbfgsWith(StiffnessFactorization* preconditioner, double tolerance,
                                     int stall_iterations, QuasistaticSolveReport* report) {
  PreconditionedLbfgsOptions lbfgs;
  lbfgs.force_tolerance = tolerance;
  lbfgs.max_iterations = options_.max_lbfgs_iterations;
  lbfgs.stall_iterations = stall_iterations;
  Eigen::Matrix3Xd x = positions();
  const PreconditionedLbfgsReport result =
      MinimizeEnergyLbfgs(lbfgs, actuation(), preconditioner, &x);
  SetPositions(x);
  report->lbfgs_iterations += result.iterations;
  report->lbfgs_stalled = report->lbfgs_stalled || result.stalled;
  report->line_search_evaluations += result.energy_evaluations;
  report->final_max_force = result.final_max_force;
  report->final_energy = result.final_energy;
  if (!report->termination.empty()) report->termination += "; ";
  report->termination += "L-BFGS: " + result.message;
}

std::string QuasistaticSolver::RefusalReason() const {
  const Eigen::Map<const ActuationMatrix> a = actuation();
  for (int e = 0; e < model_.num_elements(); ++e) {
    if (!a.col(e).allFinite()) {
      return "the actuation of element " + std::to_string(e) + " is not finite";
    }
  }
  for (size_t i = 0; i < fixed_vertices_.size(); ++i) {
    if (!fixed_positions_.col(i).allFinite()) {
      return "the prescribed position of fixed vertex " + std::to_string(fixed_vertices_[i]) +
             " is not finite";
    }
  }
  if (options_.method == EquilibriumMethod::kNewton && fixed_vertices_.empty()) {
    return "the body has no fixed vertex, so its stiffness is singular (rigid motions are "
           "free) and Newton steps are undefined: fix vertices, or use Levenberg-Marquardt";
  }
  return std::string();
}

void QuasistaticSolver::RunCeres(double tolerance, QuasistaticSolveReport* report) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver_options.dynamic_sparsity = options_.ordering == NormalEquationsOrdering::kDynamic;
  solver_options.use_postordering = options_.use_postordering;
  ceres::Problem* problem = this->problem();
  if (options_.ordering == NormalEquationsOrdering::kVertexFillReducing) {
    if (vertex_order_.empty()) vertex_order_ = FillReducingVertexOrder(model_.tets(), fixed_mask_);
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    int group = 0;
    for (int v : vertex_order_) {
      double* block = vertex(v);
      if (problem->HasParameterBlock(block)) ordering->AddElementToGroup(block, group++);
    }
    for (int v : fixed_vertices_) {
      double* block = vertex(v);
      if (problem->HasParameterBlock(block)) ordering->AddElementToGroup(block, group);
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
  ceres::Solve(solver_options, problem, &summary);

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

bool QuasistaticSolver::NewtonApplies() const {
  if (fixed_vertices_.empty()) return false;
  for (const EnergyTerm* term : terms_) {
    if (!term->SupportsStiffness()) return false;
  }
  return true;
}

QuasistaticSolveReport QuasistaticSolver::LeaveUnstableEquilibrium(double relative_size,
                                                                   unsigned seed) {
  WallTimer timer;
  QuasistaticSolveReport report;
  report.force_tolerance = ForceTolerance();
  ApplyFixedPositions();
  const bool have_stiffness = NewtonApplies();
  std::string refusal = RefusalReason();
  if (refusal.empty() && !have_stiffness) {
    refusal = "leaving an unstable equilibrium needs fixed vertices and every term's stiffness";
  }
  if (!refusal.empty()) {
    report.termination = "refused: " + refusal;
    report.refused = true;
    report.seconds = timer.Seconds();
    return report;
  }
  PerturbFreeVertices(relative_size, seed);
  report.initial_max_force = MaxFreeForce(&report.initial_energy);
  report.final_energy = report.initial_energy;
  report.final_max_force = report.initial_max_force;
  report.converged = DescendFromPerturbedState(&report);
  report.seconds = timer.Seconds();
  return report;
}

bool QuasistaticSolver::DescendFromPerturbedState(QuasistaticSolveReport* report) {
  return report->final_max_force <= report->force_tolerance ||
         RunNewton(0.0, report);  // projected steps only: exact ones are drawn back to the saddle
}

QuasistaticSolveReport QuasistaticSolver::Solve() {
  WallTimer timer;
  QuasistaticSolveReport report;
  report.force_tolerance = ForceTolerance();
  ApplyFixedPositions();
  const std::string refusal = RefusalReason();
  if (!refusal.empty()) {
    report.termination = "refused: " + refusal;
    report.refused = true;
    report.seconds = timer.Seconds();
    return report;
  }
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
    if (options_.ensure_stable && NewtonApplies()) {
      EnsureStable(&report);
      report.iterations = report.factorizations;
    }
    report.seconds = timer.Seconds();
    return report;
  }
  // Newton needs every energy term's Hessian; a free body (kLevenbergMarquardt only
  // here) has no positive definite K.
  const bool have_stiffness = NewtonApplies();
  const double newton_threshold = options_.newton_relative_force * model_.force_scale();
  if (options_.method == EquilibriumMethod::kNewton && have_stiffness) {
    // Far from equilibrium preconditioned L-BFGS (no factorization once its
    // preconditioner is built), then Newton.
    // Where Newton's exact K is indefinite well below the handover force, its projected
    // steps crawl (one factorization each): after kProjectedStepsBeforeLbfgs of them it
    // hands back to L-BFGS, which descends to kLbfgsHandBackFactor of the force, at most
    // kMaxNewtonHandBacks times (docs/solver.md, "Hand-backs").
    double threshold = newton_threshold;
    for (int round = 0;; ++round) {
      const double lbfgs_tolerance = std::max(report.force_tolerance, threshold);
      if (report.final_max_force > lbfgs_tolerance && options_.max_lbfgs_iterations > 0) {
        RunLbfgs(lbfgs_tolerance, &report);
      }
      if (report.final_max_force <= report.force_tolerance) break;
      const bool last = round == kMaxNewtonHandBacks || options_.max_lbfgs_iterations == 0;
      // Exact steps from the handover force on, in every round: L-BFGS may stop short of
      // its lowered target (its iteration limit), and exact steps held back to that
      // target left the last round to projected steps alone (a crawl to the budget).
      RunNewton(newton_threshold, &report, last ? 0 : kProjectedStepsBeforeLbfgs);
      if (last || report.newton_hand_backs == round || report.newton_stalled ||
          report.iterations >= options_.max_iterations) {
        break;
      }
      threshold = std::min(threshold, report.final_max_force) * kLbfgsHandBackFactor;
    }
  } else {
    const bool use_newton = have_stiffness && options_.newton_relative_force > 0.0;
    const double ceres_tolerance = std::max(report.force_tolerance, newton_threshold);
    bool done = false;
    if (use_newton && report.initial_max_force <= ceres_tolerance) {
      done = RunNewton(std::numeric_limits<double>::infinity(), &report);  // a warm start
    }
    // A stalled Newton phase (a kink of the energy) ends the solve: neither LM nor
    // another Newton phase gets past the kink.
    if (!done && !report.newton_stalled) {
      RunCeres(use_newton ? ceres_tolerance : report.force_tolerance, &report);
      done = report.final_max_force <= report.force_tolerance;
      if (!done && use_newton && report.final_max_force <= ceres_tolerance &&
          report.iterations < options_.max_iterations) {
        done = RunNewton(std::numeric_limits<double>::infinity(), &report);
        if (!done && !report.newton_stalled && report.iterations < options_.max_iterations) {
          RunCeres(report.force_tolerance, &report);  // Newton failed: Ceres to the end
        }
      }
    }
  }
  report.iterations = report.lm_iterations + report.factorizations;
  report.converged = report.final_max_force <= report.force_tolerance &&
                     std::isfinite(report.final_energy);
  if (report.converged && options_.ensure_stable && have_stiffness) {
    EnsureStable(&report);
    report.iterations = report.lm_iterations + report.factorizations;
  }
  report.seconds = timer.Seconds();
  return report;
}

void QuasistaticSolver::EnsureStable(QuasistaticSolveReport* report) {
  report->stability_checked = true;
  for (int escape = 0;; ++escape) {
    std::string error;
    ++report->factorizations;
    StiffnessFactorization& factorization = *OwnFactorization();
    factorization.Assemble(positions(), actuation(), StiffnessKind::kExact);
    bool stable = factorization.FactorizeAssembled(0.0, &error);
    if (!stable) {
      // Singular, not indefinite (a piece nothing holds: its zero modes round either
      // way): not a saddle to leave.
      std::string shifted_error;
      ++report->factorizations;
      stable = factorization.FactorizeAssembled(kSingularShift, &shifted_error);
    }
    if (stable) {
      report->stable = true;
      return;
    }
    if (escape == kMaxStabilityEscapes) {
      report->termination += "; the equilibrium is unstable (the exact stiffness is not "
                             "positive definite there) after " +
                             std::to_string(escape) + " attempts to leave it";
      return;
    }
    // Leave it; should the descent from the perturbed state fail, the saddle stays the
    // result (converged, not stable).
    const Eigen::Matrix3Xd saddle = positions();
    const double saddle_energy = report->final_energy;
    const double saddle_force = report->final_max_force;
    PerturbFreeVertices(kStabilityEscapeSize, 104729u + static_cast<unsigned>(escape));
    report->final_max_force = MaxFreeForce(&report->final_energy);
    if (!DescendFromPerturbedState(report)) {
      SetPositions(saddle);
      report->final_energy = saddle_energy;
      report->final_max_force = saddle_force;
      report->termination += "; the equilibrium is unstable (the exact stiffness is not "
                             "positive definite there), and the descent from a perturbation "
                             "of it failed";
      return;
    }
    ++report->unstable_escapes;
  }
}

}  // namespace aqs
