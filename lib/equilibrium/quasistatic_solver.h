#ifndef AQS_EQUILIBRIUM_QUASISTATIC_SOLVER_H_
#define AQS_EQUILIBRIUM_QUASISTATIC_SOLVER_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "equilibrium/boundary_conditions.h"
#include "physics/actuation.h"
#include "physics/shape_target_model.h"

namespace ceres {
class Problem;
}

namespace aqs {

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
  // Ceres linear solver setting. true (default) makes SPARSE_NORMAL_CHOLESKY hand the
  // Jacobian to CHOLMOD each iteration; measured ~1x one factorization per iteration
  // where the static path (false) is ~30x slower at 250K elements (docs/benchmarks.md).
  bool dynamic_sparsity = true;
  // Ceres' relative cost-change and step-size stopping tests. function_tolerance
  // 1e-15 stops only at the round-off floor of the cost (where further iterations
  // are noise); the force test above decides whether the result counts as converged.
  double function_tolerance = 1e-15;
  double parameter_tolerance = 1e-14;
};

struct QuasistaticSolveReport {
  // final_max_force <= force_tolerance.
  bool converged = false;
  // Ceres iterations after the initial evaluation (0 if the start was converged),
  // and how many of them were accepted steps.
  int iterations = 0;
  int successful_iterations = 0;
  double initial_energy = 0.0;
  double final_energy = 0.0;
  // Largest force norm |dE/dx_v| over free vertices, before and after.
  double initial_max_force = 0.0;
  double final_max_force = 0.0;
  double force_tolerance = 0.0;
  // Why the solve stopped (Ceres' termination message, or why it did not run).
  std::string termination;
  double seconds = 0.0;

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

  // Minimizes E(., actuation()) from positions(). Returns what happened; a solve that
  // does not reach the force tolerance says so (converged = false).
  QuasistaticSolveReport Solve();

  // Largest |dE/dx_v| over free vertices at the current state (and E through *energy).
  double MaxFreeForce(double* energy = nullptr) const;
  // The absolute force tolerance: relative_force_tolerance * model.force_scale().
  double ForceTolerance() const;

 private:
  void ApplyFixedPositions();
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
};

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_QUASISTATIC_SOLVER_H_
