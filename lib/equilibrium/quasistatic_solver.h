#ifndef AQS_EQUILIBRIUM_QUASISTATIC_SOLVER_H_
#define AQS_EQUILIBRIUM_QUASISTATIC_SOLVER_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "equilibrium/boundary_conditions.h"
#include "equilibrium/energy_term.h"
#include "equilibrium/stiffness_factorization.h"
#include "physics/actuation.h"
#include "physics/shape_target_model.h"

namespace ceres {
class Problem;
}

namespace aqs {

// How Ceres solves the Gauss-Newton / Levenberg-Marquardt normal equations
// (SPARSE_NORMAL_CHOLESKY with SuiteSparse in all cases). Measured in docs/benchmarks.md.
enum class NormalEquationsOrdering {
  // Ceres' static sparsity with one ordering group per free vertex, in the
  // fill-reducing order CHOLMOD picks for the vertex graph (sparse/vertex_ordering.h):
  // symbolic analysis once per solver, METIS-quality fill, no per-iteration ordering.
  kVertexFillReducing,
  // dynamic_sparsity = true: CHOLMOD re-analyzes (orders) the Jacobian every iteration.
  kDynamic,
  // Ceres' default static path: Ceres orders parameter blocks itself (block AMD).
  kCeresDefault,
};

struct QuasistaticSolverOptions {
  // Convergence: the largest residual force on a free vertex, |dE/dx_v|, is at most
  // relative_force_tolerance * model.force_scale() (the nodal force of an element
  // under unit strain). 1e-6 means equilibrium to about 1e-6 strain.
  //
  // Below ~1e-9 the test meets the floating-point floor of least squares: the cost
  // changes of such small steps are round-off (~10 eps of E), so Ceres can no longer
  // tell good steps from bad. Tighter tolerances need function_tolerance = 0 and
  // may end NOT CONVERGED at that floor.
  double relative_force_tolerance = 1e-6;
  // Ceres iterations (successful and rejected steps) at most.
  int max_iterations = 200;
  // Threads for residual/Jacobian evaluation (CHOLMOD's BLAS threads are set by
  // OPENBLAS_NUM_THREADS).
  int num_threads = 2;
  // Print Ceres' per-iteration progress lines to stdout.
  bool log_progress = false;
  // Ordering of the normal equations (see NormalEquationsOrdering).
  NormalEquationsOrdering ordering = NormalEquationsOrdering::kVertexFillReducing;
  // Ceres' use_postordering (static orderings only).
  bool use_postordering = false;
  // Exact Newton steps near equilibrium (equilibrium/newton_refinement.h). Once the
  // largest force is below newton_relative_force x force_scale (at the start, for warm
  // starts, or when Ceres gets there), the solve continues with Newton steps on the
  // exact stiffness, which converge quadratically where Levenberg-Marquardt on the
  // least-squares form converges linearly (its J^T J lacks the curvature of
  // incompatible targets). If a Newton step fails (K not positive definite, or no
  // force decrease), Ceres takes over again. 0 disables Newton: Ceres only (as do
  // energy terms without a stiffness, EnergyTerm::SupportsStiffness). Contact terms
  // (lib/contact) have one, on a pattern extended by their pairs' couplings.
  double newton_relative_force = 1e-2;
  int max_newton_steps = 8;
  // Ceres' relative cost-change and step-size stopping tests. function_tolerance
  // 1e-15 stops only at the round-off floor of the cost (where further iterations
  // are noise); the force test above decides whether the result counts as converged.
  double function_tolerance = 1e-15;
  double parameter_tolerance = 1e-14;
};

struct QuasistaticSolveReport {
  // final_max_force <= force_tolerance.
  bool converged = false;
  // Levenberg-Marquardt iterations (Ceres, after its initial evaluation) plus Newton
  // steps; and how many LM steps were accepted.
  int iterations = 0;
  int lm_iterations = 0;
  int successful_iterations = 0;
  int newton_steps = 0;
  double initial_energy = 0.0;
  double final_energy = 0.0;
  // Largest force norm |dE/dx_v| over free vertices, before and after.
  double initial_max_force = 0.0;
  double final_max_force = 0.0;
  double force_tolerance = 0.0;
  // Why the solve stopped (Ceres' termination message, Newton's, or why neither ran).
  std::string termination;
  double seconds = 0.0;
  // Ceres' own accounting (0 if Ceres did not run): problem preparation, and the
  // minimizer's time with its residual/Jacobian evaluation and linear-solver parts.
  double ceres_preprocessor_seconds = 0.0;
  double ceres_minimizer_seconds = 0.0;
  double ceres_evaluation_seconds = 0.0;
  double ceres_linear_solver_seconds = 0.0;

  // One line: converged/NOT CONVERGED, iterations, energies, forces, reason, time.
  std::string Summary() const;
};

// Finds the quasistatic equilibrium x*(a) = argmin_x E(x, a) of a ShapeTargetModel
// under fixed vertices, as a Ceres nonlinear least-squares problem made of one
// ShapeTargetCostFunction per element.
//
// Built once per mesh and boundary-condition set; then, between solves, the
// actuation is changed in place (actuation()), prescribed positions moved
// (SetFixedPositions) and the state warm-started (SetPositions); each Solve() starts
// from the current state and leaves the result in positions().
//
//   QuasistaticSolver solver(model, bc, options);
//   solver.actuation() = a;
//   QuasistaticSolveReport report = solver.Solve();
//   if (!report.converged) ...;  // report.Summary() says why
//   use(solver.positions());
//
// The model must outlive the solver. Not thread-safe; use one solver per thread.
class QuasistaticSolver {
 public:
  // bc must be valid for the model (ValidateBoundaryConditions; CHECKed).
  // The initial state is the rest shape with fixed vertices at their prescribed
  // positions, and the actuation is S = I.
  QuasistaticSolver(const ShapeTargetModel& model, const BoundaryConditions& bc,
                    const QuasistaticSolverOptions& options = QuasistaticSolverOptions());
  ~QuasistaticSolver();
  QuasistaticSolver(const QuasistaticSolver&) = delete;
  QuasistaticSolver& operator=(const QuasistaticSolver&) = delete;

  const ShapeTargetModel& model() const { return model_; }
  const QuasistaticSolverOptions& options() const { return options_; }
  void set_options(const QuasistaticSolverOptions& options) { options_ = options; }

  // Per-element actuation (6 x num_elements), read by every evaluation: change it in
  // place between solves (solver.actuation() = a; solver.actuation().col(e) = ...).
  // It is a view of storage the solver owns (assignment copies into it).
  Eigen::Map<ActuationMatrix> actuation() {
    return Eigen::Map<ActuationMatrix>(actuation_.data(), 6, model_.num_elements());
  }
  Eigen::Map<const ActuationMatrix> actuation() const {
    return Eigen::Map<const ActuationMatrix>(actuation_.data(), 6, model_.num_elements());
  }

  // Current state (3 x num_vertices): the last solution or the warm start.
  Eigen::Map<const Eigen::Matrix3Xd> positions() const {
    return Eigen::Map<const Eigen::Matrix3Xd>(positions_.data(), 3, model_.num_vertices());
  }
  // Sets the warm start. Fixed vertices are reset to their prescribed positions.
  void SetPositions(const Eigen::Matrix3Xd& positions);
  // New prescribed positions of the fixed vertices (3 x bc.vertices.size(), in the
  // order of bc.vertices); applied to the state immediately.
  void SetFixedPositions(const Eigen::Matrix3Xd& fixed_positions);

  const std::vector<int>& fixed_vertices() const { return fixed_vertices_; }
  const Eigen::Matrix3Xd& fixed_positions() const { return fixed_positions_; }
  // true for fixed vertices (num_vertices entries).
  const std::vector<bool>& fixed_mask() const { return fixed_mask_; }

  // Adds an energy term (not owned; must outlive the solver) to the equilibrium:
  // the solver then minimizes E(x, a) + the terms. Call before Solve(), and before
  // taking stiffness_factorization(): a term with vertex couplings replaces it.
  void AddEnergyTerm(const EnergyTerm* term);
  const std::vector<const EnergyTerm*>& energy_terms() const { return terms_; }

  // Minimizes E(., actuation()) (plus energy terms) from positions(). Returns what happened; a solve that
  // does not reach the force tolerance says so (converged = false).
  QuasistaticSolveReport Solve();

  // Largest |dE/dx_v| over free vertices at the current state (and E through *energy;
  // both include the energy terms).
  double MaxFreeForce(double* energy = nullptr) const;
  // The absolute force tolerance: relative_force_tolerance * model.force_scale().
  double ForceTolerance() const;

  // The stiffness factorization the Newton steps use (created on first use, its pattern
  // with the energy terms' couplings), to share with an EquilibriumDifferentiator so
  // that one CHOLMOD factor serves both.
  StiffnessFactorization* stiffness_factorization();

 private:
  void ApplyFixedPositions();
  // Runs Ceres from the current state to the absolute force `tolerance`.
  void RunCeres(double tolerance, QuasistaticSolveReport* report);
  // Newton steps from the current state; true if the force tolerance was reached.
  bool RunNewton(QuasistaticSolveReport* report);
  double* vertex(int v) { return positions_.data() + 3 * static_cast<size_t>(v); }

  const ShapeTargetModel& model_;
  QuasistaticSolverOptions options_;
  std::vector<int> fixed_vertices_;
  Eigen::Matrix3Xd fixed_positions_;
  std::vector<bool> fixed_mask_;
  // Fixed-size storage that Ceres' cost functions and parameter blocks point into:
  // never reallocated, only written through.
  std::vector<double> actuation_;
  std::vector<double> positions_;
  std::unique_ptr<ceres::Problem> problem_;
  std::unique_ptr<StiffnessFactorization> factorization_;
  std::vector<const EnergyTerm*> terms_;
  // Free vertices in fill-reducing order (computed on the first Solve that needs it).
  std::vector<int> vertex_order_;
};

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_QUASISTATIC_SOLVER_H_
